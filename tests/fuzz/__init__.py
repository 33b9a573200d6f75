"""Fuzz harnesses: seeded mutations of decks, FRF files, calibration configs and RPC III files."""
