"""Membership functions of the linguistic terms (the fuzzy sets of the FIS inputs and
outputs), with scikit-fuzzy's formulas and branch structure."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["SHAPES", "trimf", "trapmf", "gaussmf", "membership"]

_Floats = npt.NDArray[np.float64]

#: Membership shapes and their number of parameters.
SHAPES = {"trimf": 3, "trapmf": 4, "gaussmf": 2}


def trimf(x: _Floats, a: float, b: float, c: float) -> _Floats:
    """skfuzzy.trimf on an array of any shape (same branch structure and formulas)."""
    y = np.zeros_like(x)
    if a != b:
        y = np.where((a < x) & (x < b), (x - a) / float(b - a), y)
    if b != c:
        y = np.where((b < x) & (x < c), (c - x) / float(c - b), y)
    return np.where(x == b, 1.0, y)


def trapmf(x: _Floats, a: float, b: float, c: float, d: float) -> _Floats:
    """skfuzzy.trapmf on an array of any shape."""
    y = np.ones_like(x)
    y = np.where(x <= b, trimf(x, a, b, b), y)
    y = np.where(x >= c, trimf(x, c, c, d), y)
    return np.where((x < a) | (x > d), 0.0, y)


def gaussmf(x: _Floats, mean: float, sigma: float) -> _Floats:
    """skfuzzy.gaussmf."""
    y: _Floats = np.exp(-((x - mean) ** 2.0) / (2 * sigma**2.0))
    return y


_MF: dict[str, Callable[..., _Floats]] = {"trimf": trimf, "trapmf": trapmf, "gaussmf": gaussmf}


def membership(shape: str, params: Sequence[float], x: npt.ArrayLike) -> _Floats:
    """Membership degree of ``x`` (any shape) in a term ``{shape, params}``."""
    return _MF[shape](np.asarray(x, dtype=float), *params)
