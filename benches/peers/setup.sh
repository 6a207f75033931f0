#!/usr/bin/env bash
# The race's Python environment (outside CI): MuJoCo, Exudyn and Pinocchio from PyPI, and
# SciPy for the independent reference, in benches/peers/.venv (ignored by git).
set -euo pipefail
cd "$(dirname "$0")"
python3 -m venv .venv
.venv/bin/pip install -q -r requirements.txt
.venv/bin/python -c "import mujoco, exudyn, pinocchio, scipy; print('mujoco', mujoco.__version__, '· exudyn', exudyn.__version__, '· pinocchio', pinocchio.__version__, '· scipy', scipy.__version__)"
