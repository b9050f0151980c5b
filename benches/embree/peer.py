#!/usr/bin/env python3
"""Embree (through the `embreex` package) as optik's CPU peer: the same mesh, the same rays.

Usage: peer.py VERTICES.npy TRIANGLES.npy RAYS.npy OUT.npz --threads N --repeat K [--fast]
              [--prim-npy PRIM.npy] [--t-npy T.npy]

Reads float32 vertices (V, 3), uint32 triangles (F, 3) and rays (N, 8: origin xyz, tmin, direction
xyz, tmax), builds an Embree scene (robust mode unless --fast), traces every ray with
rtcIntersect1 on one thread and then on N threads (chunks traced from a thread pool; embreex
releases the GIL around its loop), writes the hits (t, prim, u, v) to OUT.npz and prints one
JSON line: build_s, trace_s_1 (one thread), trace_s_n (N threads), best of K repeats each.
--prim-npy and --t-npy also write the hit triangles (uint32, 0xFFFFFFFF on a miss) and distances
(float32, inf on a miss) as plain .npy files, which optik's bench-cpu reads to count disagreements.
embreex cannot set tnear: rays must have tmin = 0 for an exact comparison.
"""
import argparse
import json
import sys
import time
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

    bestn = float("inf")
    with ThreadPoolExecutor(max_workers=a.threads) as pool:
        for _ in range(max(1, a.repeat)):
            t0 = time.perf_counter()
            list(pool.map(lambda chunk: trace(*chunk), work))
            bestn = min(bestn, time.perf_counter() - t0)

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
                      "threads": a.threads, "rays": n, "robust": not a.fast}))


if __name__ == "__main__":
    main()
