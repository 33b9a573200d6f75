"""Test data: FRF data sets with their channels and units (:mod:`~femcal.testdata.data`),
time histories (:mod:`~femcal.testdata.timedata`), the file formats both are read from and
written to, by suffix (:mod:`~femcal.testdata.formats`), and one set from several
measurement runs (:mod:`~femcal.testdata.runs`)."""

from .data import Channel, FRFData, convert_units, quantity_of_units
from .formats import read_frf, read_time_data, write_frf, write_time_data
from .runs import assemble_runs
from .timedata import TimeData

__all__ = [
    "Channel",
    "FRFData",
    "TimeData",
    "assemble_runs",
    "convert_units",
    "quantity_of_units",
    "read_frf",
    "read_time_data",
    "write_frf",
    "write_time_data",
]
