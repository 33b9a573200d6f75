"""Files at the edge: atomic writes, result files of a solution, identified models and
calibration reports."""
