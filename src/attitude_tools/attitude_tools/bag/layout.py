"""The on-disk layout shared by the bag writer, reader and recovery: file names, magic."""

from __future__ import annotations

__all__ = ["MCAP_MAGIC", "METADATA_FILE", "RESERVE_FILE"]

METADATA_FILE = "metadata.yaml"
RESERVE_FILE = ".reserve"
MCAP_MAGIC = b"\x89MCAP0\r\n"
