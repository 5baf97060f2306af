"""Readers and writers for the file formats avtrack consumes and produces."""

from avtrack.io.base import atomic_write
from avtrack.io.mot import MOTData, read_mot, write_mot

__all__ = ["MOTData", "atomic_write", "read_mot", "write_mot"]
