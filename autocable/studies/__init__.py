"""Studies built on the core: the method ladder (`ladder`), `advise` (the lightest method a scene
needs), work-precision charts, the Multiple Scales ordering against eq. (21), the failure map and
the calibration of the paper's unknown inputs."""
