"""Build one model file with the default functions into a given cache and print the build's Python and gcc
CPU, wall time and C size (benchmarks/results/spin_table.md: run once per eomc version, e.g. with
PYTHONPATH pointing at an older checkout's package tree).

Usage: python benchmarks/spin_table_build.py MODEL.xml CACHE_DIR
"""
import sys, time, resource, os, warnings
import eomc
path = sys.argv[1]; cache = sys.argv[2]
t0 = time.process_time(); w0 = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    m = eomc.compile(path, cache_dir=cache)
ch = resource.getrusage(resource.RUSAGE_CHILDREN)
import eomc.compiler.contact.table  # noqa: E402
print(f"{eomc.compiler.contact.table.__file__}: python CPU {time.process_time()-t0:.1f} s, gcc CPU {ch.ru_utime+ch.ru_stime:.1f} s, wall {time.perf_counter()-w0:.1f} s, C {os.path.getsize(m.source_path)/1e6:.2f} MB, lib {m.library_path}")
