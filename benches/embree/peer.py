#!/usr/bin/env python3
"""Embree (through the `embreex` package) as optik's CPU peer: the same mesh, the same rays.

Usage: peer.py VERTICES.npy TRIANGLES.npy RAYS.npy OUT.npz --threads N --repeat K [--fast]
              [--prim-npy PRIM.npy] [--t-npy T.npy]

Reads float32 vertices (V, 3), uint32 triangles (F, 3) and rays (N, 8: origin xyz, tmin, direction
xyz, tmax), builds an Embree scene (robust mode unless --fast), traces every ray with
rtcIntersect1 on one thread and then on N (N forked processes sharing the committed scene, one
chunk each, timed between two barriers: Embree's N threads as a C++ program drives them, with
no Python interpreter lock between them), writes the hits (t, prim, u, v) to OUT.npz and prints
one JSON line: build_s, trace_s_1 (one thread), trace_s_n (N processes), trace_s_pool (the
same chunks from a pool of N threads of this process, the figure trace_s_n gave before
2026-12-06), best of K repeats each.
--prim-npy and --t-npy also write the hit triangles (uint32, 0xFFFFFFFF on a miss) and distances
(float32, inf on a miss) as plain .npy files, which optik's bench-cpu reads to count disagreements.
embreex cannot set tnear: rays must have tmin = 0 for an exact comparison.
"""
import argparse
import json
import multiprocessing
import sys
import time
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

try:
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh
except ImportError as e:  # pragma: no cover - reported to the caller as JSON
    print(json.dumps({"error": f"embreex is not installed ({e}); pip install embreex numpy"}))
    sys.exit(2)


# Runs of rays gathered into each thread's chunk for the timed multi-threaded passes.
PIECES = 8


def main():
    p = argparse.ArgumentParser()
    p.add_argument("vertices")
    p.add_argument("triangles")
    p.add_argument("rays")
    p.add_argument("out")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--fast", action="store_true", help="Embree's default (non-robust) kernels")
    p.add_argument("--prim-npy", help="also write the hit triangles (uint32, 0xFFFFFFFF: miss) here")
    p.add_argument("--t-npy", help="also write the hit distances (float32, inf: miss) here")
    a = p.parse_args()

    vertices = np.load(a.vertices).astype(np.float32)
    triangles = np.load(a.triangles).astype(np.int32)
    rays = np.load(a.rays).astype(np.float32)
    if rays.ndim != 2 or rays.shape[1] != 8:
        print(json.dumps({"error": f"rays shape {rays.shape}; expected (N, 8)"}))
        sys.exit(2)
    origins = np.ascontiguousarray(rays[:, 0:3])
    directions = np.ascontiguousarray(rays[:, 4:7])
    dists = np.ascontiguousarray(rays[:, 7])

    start = time.perf_counter()
    scene = rtcs.EmbreeScene(robust=not a.fast)
    TriangleMesh(scene, vertices, triangles)
    # The scene commits (builds) lazily on the first query.
    scene.run(origins[:1], directions[:1], dists=dists[:1])
    build_s = time.perf_counter() - start

    def trace(o, d, t):
        return scene.run(o, d, dists=t, query="INTERSECT", output=1)

    n = len(rays)
    best1 = float("inf")
    for _ in range(max(1, a.repeat)):
        t0 = time.perf_counter()
        res = trace(origins, directions, dists)
        best1 = min(best1, time.perf_counter() - t0)

    # One chunk per thread: each `scene.run` call holds the GIL while it converts its inputs
    # and allocates its outputs, so small chunks serialise the threads on that (with 8 chunks
    # per thread, 16 threads reached only 1.2-2.6x one thread's throughput on a 16-core machine).
    # But a contiguous chunk of camera rays is a band of the image, and bands differ in cost
    # (sky against geometry): with one band per thread the slowest band set the time. So each
    # thread's chunk is gathered, before timing, from PIECES runs of rays spread over the set
    # (piece k of thread t is run t + k * threads): neighbouring rays stay neighbours within a
    # piece, and every thread gets a share of every part of the image.
    chunks = max(1, a.threads)
    runs = chunks * PIECES
    run_bounds = [(i * n // runs, (i + 1) * n // runs) for i in range(runs)]
    work = []
    for c in range(chunks):
        picked = [run_bounds[k] for k in range(c, runs, chunks)]
        gather = lambda x: np.ascontiguousarray(np.concatenate([x[lo:hi] for lo, hi in picked]))
        work.append((gather(origins), gather(directions), gather(dists)))
    if sum(len(w[0]) for w in work) != n:
        print(json.dumps({"error": "the threads' chunks do not cover the rays once"}))
        sys.exit(2)

    bestn = timed_in_processes(trace, work, max(1, a.repeat))
    best_pool = float("inf")
    with ThreadPoolExecutor(max_workers=a.threads) as pool:
        for _ in range(max(1, a.repeat)):
            t0 = time.perf_counter()
            list(pool.map(lambda chunk: trace(*chunk), work))
            best_pool = min(best_pool, time.perf_counter() - t0)

    prim = res["primID"].astype(np.int64)
    hit = prim >= 0
    t = np.where(hit, res["tfar"], np.inf).astype(np.float32)
    prim32 = np.where(hit, prim, 0xFFFFFFFF).astype(np.uint32)
    np.savez(a.out, t=t, prim=prim32, u=res["u"].astype(np.float32), v=res["v"].astype(np.float32))
    if a.prim_npy:
        np.save(a.prim_npy, prim32)
    if a.t_npy:
        np.save(a.t_npy, t)
    print(json.dumps({"build_s": build_s, "trace_s_1": best1, "trace_s_n": bestn,
                      "trace_s_pool": best_pool, "threads": a.threads, "rays": n,
                      "robust": not a.fast}))


def timed_in_processes(trace, work, repeat):
    """The best of `repeat` passes of every chunk of `work` traced at once, one forked process
    a chunk: the processes share the committed scene's memory (copy on write, only read). A
    pass lasts from the first process's start to the last one's end, each read from the
    system's monotonic clock in the process itself (this process, which waits, may not get a
    core until a tracing one is done).

    A pool of threads in this process measured less than Embree's threads give: each
    `scene.run` call converts its inputs and allocates its outputs holding the interpreter
    lock, and on a 2-core machine two threads reached only 1.3x one thread's rate on the
    Breakfast Room's camera rays where two processes reached 2x or more."""
    context = multiprocessing.get_context("fork")
    barrier = context.Barrier(len(work))
    # Per pass and process: its start and end (time.perf_counter is CLOCK_MONOTONIC, one
    # clock for every process on Linux).
    times = context.Array("d", repeat * len(work) * 2, lock=False)

    def run(k, chunk):
        try:
            for r in range(repeat):
                barrier.wait()
                at = (r * len(work) + k) * 2
                times[at] = time.perf_counter()
                trace(*chunk)
                times[at + 1] = time.perf_counter()
        except BaseException:
            # The others would wait at the next pass's barrier for ever: break it, so they
            # fail too and the parent reports the failure instead of hanging.
            barrier.abort()
            raise

    with warnings.catch_warnings():
        # Python warns that forking a multi-threaded process may deadlock in the child;
        # the children only trace (Embree's tracing starts no threads and takes no locks).
        warnings.simplefilter("ignore", DeprecationWarning)
        workers = [context.Process(target=run, args=(k, c)) for k, c in enumerate(work)]
        for w in workers:
            w.start()
    for w in workers:
        w.join()
    if any(w.exitcode != 0 for w in workers):
        print(json.dumps({"error": "a tracing process failed"}))
        sys.exit(2)
    passes = [times[r * len(work) * 2:(r + 1) * len(work) * 2] for r in range(repeat)]
    return min(max(p[1::2]) - min(p[0::2]) for p in passes)


if __name__ == "__main__":
    main()
