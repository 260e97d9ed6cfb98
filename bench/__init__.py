"""Benchmarks of the planner (``make bench``): timings, Table 2, and a race against OMPL."""
