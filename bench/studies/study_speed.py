#!/usr/bin/env python3
"""Studies' speed (docs/performance.md, "Studies"), every figure from one run of this script:
`kanedyn sweep` of 2,000 runs of 1 s of the eight-body figure on 1 and 2 threads, the same
study by Study.run() on a dask cluster of 2 local worker processes (one thread each), and the
dask path's cost per chunk (chunks of one run against chunks of 50, on the same cluster).
The three ways take turns, --rounds times, and the best time of each is kept: on a shared VM
the second core is not always there, and a round in which it was away says nothing of the
code.

    PYTHONPATH=build/python python3 bench/studies/study_speed.py [--runs 2000] [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import pathlib
import shutil
import subprocess
import tempfile
import time

import distributed

import kanedyn

ROOT = pathlib.Path(__file__).resolve().parents[2]

STUDY = """format: kanedyn-study/1
model: eight_body.yaml
seed: 1
runs: {runs}
vary:
  - key: forces[1].stiffness
    uniform: [2.0e4, 8.0e4]
  - key: bodies[head].mass
    normal: {{mean: 5.0, std: 0.5}}
simulate: {{t_end: 1.0, dt_out: 0.01}}
outputs:
  - final: head.z
  - max: head.z
  - rms: torso.w1
  - min: energy
"""


def timed(label: str, fn) -> float:
    start = time.perf_counter()
    fn()
    seconds = time.perf_counter() - start
    print(f"{label:<44} {seconds:8.3f} s")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--tool", default=str(ROOT / "build" / "kanedyn"))
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="kanedyn-study-speed-"))
    try:
        shutil.copy(ROOT / "examples" / "eight_body.yaml", work / "eight_body.yaml")
        study = work / "study.yaml"
        study.write_text(STUDY.format(runs=args.runs))

        def sweep(threads: int, round_: int) -> None:
            out = work / f"sweep{threads}_{round_}"
            subprocess.run([args.tool, "sweep", study, "-o", out, "-j", str(threads)], check=True,
                           capture_output=True)

        def side_by_side(round_: int) -> None:
            # The machine's own scaling: two independent one-thread sweeps at once.
            procs = [subprocess.Popen([args.tool, "sweep", study, "-o", work / f"pair{k}_{round_}", "-j", "1"],
                                      stdout=subprocess.DEVNULL) for k in range(2)]
            for p in procs:
                assert p.wait() == 0

        one, two, dask, t1, t50, pair = [], [], [], [], [], []
        small = 200
        with distributed.LocalCluster(host="127.0.0.1", processes=True, n_workers=2, threads_per_worker=1,
                                      dashboard_address=None) as cluster, distributed.Client(cluster) as client:
            s = kanedyn.Study(study)
            # The workers' first chunk parses the study: warm them up on a study of its own.
            warm = work / "warm.yaml"
            warm.write_text(STUDY.format(runs=2))
            kanedyn.Study(warm).run(out=work / "warm", client=client, chunk_size=1)
            sub = work / "small.yaml"
            sub.write_text(STUDY.format(runs=small))
            s_small = kanedyn.Study(sub)
            for r in range(args.rounds):
                one.append(timed(f"kanedyn sweep, {args.runs} runs, -j 1", lambda: sweep(1, r)))
                two.append(timed(f"kanedyn sweep, {args.runs} runs, -j 2", lambda: sweep(2, r)))
                pair.append(timed("two sweeps -j 1 side by side (processes)", lambda: side_by_side(r)))
                dask.append(timed("Study.run, dask, 2 workers, default chunks",
                                  lambda: s.run(out=work / f"dask{r}", client=client)))
                t1.append(timed(f"Study.run, dask, {small} runs, chunks of 1",
                                lambda: s_small.run(out=work / f"c1_{r}", client=client, chunk_size=1)))
                t50.append(timed(f"Study.run, dask, {small} runs, chunks of 50",
                                 lambda: s_small.run(out=work / f"c50_{r}", client=client, chunk_size=50)))
        one, two, dask, t1, t50, pair = min(one), min(two), min(dask), min(t1), min(t50), min(pair)
        print(f"best of {args.rounds}: -j 1 {one:.3f} s, -j 2 {two:.3f} s, dask {dask:.3f} s")
        tables = [(work / d / "results.csv").read_text().splitlines() for d in ("sweep1_0", "sweep2_0", "dask0")]
        same = all([line.rsplit(",", 1)[0] for line in t] == [line.rsplit(",", 1)[0] for line in tables[0]]
                   for t in tables)
        print(f"the three tables are the same (wall_s aside): {same}")
        print(f"the machine: two processes do    {2 * one / pair:.2f}x the work of one in the same time")
        print(f"sweep -j 2 / -j 1 speed-up:      {one / two:.2f}x")
        print(f"dask 2 workers / -j 1 speed-up:  {one / dask:.2f}x")
        print(f"runs per second per core (-j 1): {args.runs / one:.0f}")
        # Chunks of 1 cost 200 chunks, chunks of 50 cost 4: the difference is 196 chunks' cost,
        # shared by 2 workers working side by side.
        print(f"dask cost per chunk:             {(t1 - t50) * 2 / (small - small // 50) * 1e3:.1f} ms")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    main()
