"""Rigid-body spacecraft attitude simulator node package."""
