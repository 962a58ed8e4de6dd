"""One BLAS thread per test process, as the process pool gives its workers
(``vsegen.harness.jobs.pool.ONE_THREAD``): pytest-xdist runs one worker per core, and a BLAS
thread that spins while the other worker holds the core slows both (kf2dof's calibration test
took 23 s of CPU for 13 s alone, 48 s inside the suite). conftest imports this module before
anything loads NumPy; the commands the tests start inherit the setting."""

import os

from vsegen.harness.jobs.pool import ONE_THREAD

for variable, value in ONE_THREAD.items():
    os.environ.setdefault(variable, value)
