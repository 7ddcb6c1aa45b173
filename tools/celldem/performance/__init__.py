"""Performance tools: the scaling table of `celldem bench --scaling` (bench, tools/plot_bench.py), the roofline
of a time step (roofline, tools/roofline.py; roofline_probe.cpp measures the core's clock, FMA rate and bandwidths),
and two binaries compared (tools/compare_binaries.py): their speed in concurrent pinned pairs (paired), their
results on paired seeds (equivalence).
"""
