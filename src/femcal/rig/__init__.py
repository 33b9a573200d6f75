"""The frame on its rig: actuators driven in displacement at the grounded end of their oil
columns (:mod:`~femcal.rig.plant`), and its time simulation (:mod:`~femcal.rig.simulate`)."""
