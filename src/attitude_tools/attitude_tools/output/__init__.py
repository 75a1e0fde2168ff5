"""Output directories published whole, and strict JSON."""
