"""Test data: FRF data sets with their channels and units, the file formats they are read
from and written to, and synthetic tests made from a model."""
