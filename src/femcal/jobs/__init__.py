"""Whole jobs, files in and files out, as the command line runs them: a calibration from its
configuration file (:mod:`~femcal.jobs.calibration`), a synthetic hammer test from a deck
(:mod:`~femcal.jobs.synthetic_test`). Each reads its inputs, calls the library, and writes its
results atomically; the library below them takes and returns data."""
