"""Recorder node and launch file of the attitude stack."""
