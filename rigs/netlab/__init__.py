"""Hosts on one machine: Linux network namespaces joined by a switch, for tests and benchmarks of
what crosses a network (rigs/netlab/lab.py); a lossy radio link in user space (air.py)."""
