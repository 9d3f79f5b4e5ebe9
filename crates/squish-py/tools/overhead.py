"""The Python call's overhead over the Rust call (docs/python.md): times squish.deform on two
mesh files and the Rust example `deform_timing` on the same files, alternating, and prints both
medians. Usage: python overhead.py DEFORM_TIMING_BINARY A B ROUNDS."""

import statistics
import subprocess
import sys
import time

import squish

binary, a_path, b_path, rounds = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
a, b = squish.read_mesh(a_path), squish.read_mesh(b_path)
squish.deform(a, b)  # warm up
python_ms, rust_ms = [], []
for _ in range(5):
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        squish.deform(a, b)
        times.append((time.perf_counter() - start) * 1e3)
    python_ms.append(statistics.median(times))
    rust_ms.append(float(subprocess.run([binary, a_path, b_path, str(rounds)], capture_output=True, text=True, check=True).stdout))
print(f"vertices {a.num_vertices} + {b.num_vertices}")
print(f"python median of medians {statistics.median(python_ms):.2f} ms  {python_ms}")
print(f"rust   median of medians {statistics.median(rust_ms):.2f} ms  {rust_ms}")
print(f"overhead {100 * (statistics.median(python_ms) / statistics.median(rust_ms) - 1):+.1f}%")
