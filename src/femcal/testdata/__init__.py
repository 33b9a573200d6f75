"""Test data: FRF data sets with their channels and units (:mod:`~femcal.testdata.data`),
the file formats they are read from and written to (:mod:`~femcal.testdata.formats`), and
one set from several measurement runs (:mod:`~femcal.testdata.runs`)."""

from .data import Channel, FRFData, convert_units, quantity_of_units
from .formats import read_frf, write_frf
from .runs import assemble_runs

__all__ = [
    "Channel",
    "FRFData",
    "assemble_runs",
    "convert_units",
    "quantity_of_units",
    "read_frf",
    "write_frf",
]
