"""Fuzz harnesses: seeded mutations of decks, FRF files and calibration configs."""
