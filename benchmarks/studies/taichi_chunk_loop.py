"""Does Taichi's CPU backend run an outer range-for of a few chunks (each an inner serial loop) on all threads?

This is the shape of taichi_mpm's private-grid P2G (``MPMSolver.g2p_p2g``: ``for t in range(n_chunks)``, each chunk
a serial loop over its points). Measured on the 2-core CI-like machine, taichi 1.7.4, 2026-11-22:

    python benchmarks/studies/taichi_chunk_loop.py chunks 1   -> cores 1.0
    python benchmarks/studies/taichi_chunk_loop.py chunks 2   -> cores 1.0  (16 or 64 chunks, with or without
                                                         ti.loop_config(block_dim=1) or parallelize=2)
    python benchmarks/studies/taichi_chunk_loop.py flat 2     -> cores 1.98 (one flat range-for of 32M iterations)

Usage: python benchmarks/studies/taichi_chunk_loop.py {chunks|flat} THREADS
"""
import resource
import sys
import time

import taichi as ti

shape, n = sys.argv[1], int(sys.argv[2])
ti.init(arch=ti.cpu, cpu_max_num_threads=n)
N_CHUNKS, PER_CHUNK = 16, 2_000_000
a = ti.field(ti.f32, shape=N_CHUNKS * PER_CHUNK)


@ti.kernel
def chunks():
    ti.loop_config(block_dim=1)
    for t in range(N_CHUNKS):
        s = 0.0
        for i in range(PER_CHUNK):
            s += ti.sin(i * 0.001 + t)
            a[t * PER_CHUNK + i] = s


@ti.kernel
def flat():
    for i in range(N_CHUNKS * PER_CHUNK):
        a[i] = ti.sin(i * 0.001) * ti.cos(i * 0.002) + ti.sqrt(i * 1.0)


kernel = chunks if shape == "chunks" else flat
kernel()
ti.sync()
r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
for _ in range(5):
    kernel()
ti.sync()
wall, r1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_SELF)
cpu = r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime
print(f"{shape} threads={n}: wall {wall:.3f} s, cores used {cpu / wall:.2f}")
