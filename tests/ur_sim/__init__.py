"""A protocol-level simulator of a Universal Robots controller (RTDE, dashboard, script
ports, Modbus) for testing clients that use the real ur_rtde library; see README.md.
Run it as a process: PYTHONPATH=tests python -m ur_sim --help."""
