"""Performance tools: the scaling table of `celldem bench --scaling` (bench, tools/plot_bench.py) and the roofline
of a time step (roofline, tools/roofline.py; roofline_probe.cpp measures the core's clock, FMA rate and bandwidths).
"""
