"""The rehearsal link (``link.*``) and the offline loop behind it
(:mod:`attitude_core.world.link`, :mod:`attitude_core.loop.linked_loop`), judged on the
true body: outages anywhere in a slew, a link that dies, latency, jitter and losses;
the scenario's checks of ``link.*`` and ``fdir.*``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.contract.faults import FaultKind
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.link_spec import LinkSpec
from attitude_core.record.summary import summarize
from attitude_core.world.link import StateLink

ROOT = Path(__file__).resolve().parents[2]
DT_NS = 100_000_000


def case2(**extra):
    doc = yaml.safe_load((ROOT / "scenarios" / "case2.yaml").read_text())
    doc["/**"]["ros__parameters"].update(extra)
    return loads_scenario(yaml.safe_dump(doc), "case2 with a link")


def test_link_withholds_outages_and_delivers_the_newest_due_state():
    link: StateLink[int] = StateLink(LinkSpec(state_latency_s=0.25, outages=((1.0, 0.5),)))
    got = {}
    for k in range(30):
        link.send(k * DT_NS, k)
        r = link.receive(k * DT_NS)
        if r is not None:
            got[k] = r
    # 0.25 s late: state k due at k + 2.5 steps, delivered at tick k + 3
    assert got[3] == (0, 0) and got[12] == (9 * DT_NS, 9)
    assert all(got.get(k + 3, (None, None))[1] != k for k in range(10, 15))  # withheld
    assert link.withheld == 5 and link.lost == 0


def test_link_losses_are_a_binomial_draw_and_reproducible_for_a_seed():
    def run(seed):
        link: StateLink[int] = StateLink(LinkSpec(drop_rate=0.1, jitter_s=0.05, seed=seed))
        out = []
        for k in range(4000):
            link.send(k * DT_NS, k)
            r = link.receive(k * DT_NS)
            out.append(None if r is None else r[1])
        return link, out

    link, a = run(5)
    assert run(5)[1] == a and run(6)[1] != a
    # 4000 draws at p = 0.1: mean 400, sd 19
    assert 320 < link.lost < 480
    delivered = [x for x in a if x is not None]
    assert delivered == sorted(delivered)  # never an older state after a newer one


def test_a_link_that_impairs_nothing_flies_the_run_of_no_link_bit_for_bit():
    plain, linked = run_closed_loop(case2()), run_closed_loop(case2(link={"seed": 1}))
    for field in ("sigma_bn", "omega_b", "torque_b", "sigma_t"):
        assert np.array_equal(getattr(plain, field), getattr(linked, field)), field
    assert linked.faults == []


@pytest.mark.parametrize("start_s", [0.5, 8.0, 20.0, 31.3, 44.0])
def test_three_seconds_without_a_state_anywhere_in_the_slew_is_safe_and_reached(start_s):
    clean = summarize(run_closed_loop(case2()))
    run = run_closed_loop(case2(link={"outages": [start_s, 3.0]}))
    s = summarize(run)
    assert s.reached and s.min_margin_deg > 0.0
    assert s.min_margin_deg > clean.min_margin_deg - 0.5  # the guidance's margin, nearly
    assert s.t_reach_s < clean.t_reach_s + 10.0
    (fault,) = run.faults
    assert fault.kind is FaultKind.STATE_LOST
    assert fault.t_start_s == pytest.approx(start_s - 0.1 + 0.3, abs=0.11)
    assert fault.t_end_s == pytest.approx(start_s + 3.0, abs=0.11)


def test_a_link_that_dies_is_braked_ends_in_safe_mode_and_the_run_stops():
    run = run_closed_loop(case2(link={"outages": [20.0, 1.0e6]}))
    s = summarize(run)
    assert s.min_margin_deg > 0.0 and not s.reached
    kinds = [f.kind for f in run.faults]
    assert kinds == [FaultKind.STATE_LOST, FaultKind.SAFE_MODE]
    assert run.faults[1].t_start_s == pytest.approx(29.9)
    assert run.t[-1] == pytest.approx(30.0)  # the run ends at the tick that sees it
    assert np.degrees(s.final_rate_rad_s) < 0.5


def test_latency_jitter_and_losses_are_flown_safely():
    run = run_closed_loop(
        case2(link={"state_latency_s": 0.1, "jitter_s": 0.05, "drop_rate": 0.1, "seed": 9})
    )
    s = summarize(run)
    assert s.reached and s.min_margin_deg > 2.5
    assert all(f.kind is FaultKind.STATE_LOST and f.t_end_s is not None for f in run.faults)


@pytest.mark.parametrize(
    ("extra", "key", "reason"),
    [
        ({"link": {"outages": [1.0]}}, "link.outages", "pairs"),
        ({"link": {"outages": [1.0, 0.0]}}, "link.outages", "duration > 0"),
        ({"link": {"drop_rate": 1.0}}, "link.drop_rate", ""),
        (
            {"link": {"state_latency_s": 0.2, "jitter_s": 0.15}},
            "link.state_latency_s",
            "below fdir.state_timeout_s",
        ),
        ({"fdir": {"predict_s": 0.2}}, "fdir.predict_s", "above fdir.state_timeout_s"),
        ({"fdir": {"safe_after_s": 3.0}}, "fdir.safe_after_s", "above fdir.predict_s"),
    ],
)
def test_bad_link_and_fdir_keys_are_refused_naming_the_key(extra, key, reason):
    with pytest.raises(ScenarioError) as err:
        case2(**extra)
    assert key in str(err.value) and reason in str(err.value)


def test_a_link_with_sensors_is_refused():
    doc = yaml.safe_load((ROOT / "scenarios" / "case1_wheels_sensors.yaml").read_text())
    doc["/**"]["ros__parameters"]["link"] = {"drop_rate": 0.1}
    with pytest.raises(ScenarioError, match="link.*not supported"):
        loads_scenario(yaml.safe_dump(doc), "sensors and a link")
