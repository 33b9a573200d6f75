"""Model calibration: parameters, exact parameter derivatives of K and M, the reduced
surrogate and the FRF deviation metric, Levenberg-Marquardt within bounds, Cramér-Rao
bounds, and the whole study's workflow (see :mod:`femcal.calibrate.workflow`)."""
