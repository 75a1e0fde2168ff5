"""FEPF attitude guidance node package."""
