"""kanedyn.Study: the same results.csv from `kanedyn sweep`, Study.run() on threads and on a
dask.distributed cluster (1 and 3 workers, one of them killed mid-study), and a driver killed
and started again."""

from __future__ import annotations

import os
import pathlib
import shutil
import signal
import subprocess
import sys
import threading
import time
from typing import Iterator, List

import numpy as np
import pytest

import kanedyn

from conftest import EXAMPLES, run_tool

distributed = pytest.importorskip("distributed")  # Debian: python3-distributed

PYTHON = sys.executable


def study_text(runs: int, t_end: float) -> str:
    """A study of the eight-body figure: `runs` draws of a bushing's stiffness and the torso's
    initial rate at each of two head masses; every 25th trajectory kept."""
    return f"""format: kanedyn-study/1
model: eight_body.yaml
seed: 5
runs: {runs}
vary:
  - key: bodies[head].mass
    grid: [4.0, 6.0]
  - key: forces[1].stiffness
    lognormal: {{mu: 10.5, sigma: 0.3}}
  - key: bodies[torso].initial.angular_velocity[0]
    normal: {{mean: 0.0, std: 0.5}}
simulate: {{t_end: {t_end}, dt_out: 0.01}}
outputs:
  - final: head.z
  - max: torso.w1
  - rms: pelvis.z
  - min: energy
trajectories: every 25
"""


def make_study(folder: pathlib.Path, runs: int, t_end: float) -> pathlib.Path:
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(EXAMPLES / "eight_body.yaml", folder / "eight_body.yaml")
    (folder / "study.yaml").write_text(study_text(runs, t_end))
    return folder / "study.yaml"


def without_wall(results: pathlib.Path) -> List[str]:
    """results.csv's lines without their last field, wall_s, the one that may differ."""
    return [line.rsplit(",", 1)[0] for line in results.read_text().splitlines()]


def same_trajectories(a: pathlib.Path, b: pathlib.Path) -> None:
    names = sorted(p.name for p in (a / "runs").iterdir())
    assert names == sorted(p.name for p in (b / "runs").iterdir())
    assert names
    for name in names:
        assert (a / "runs" / name).read_bytes() == (b / "runs" / name).read_bytes(), name


@pytest.fixture
def study(tmp_path: pathlib.Path) -> pathlib.Path:
    path = make_study(tmp_path, 20, 0.3)
    done = run_tool(["sweep", path, "-o", tmp_path / "sweep", "-j", "2"])
    assert done.returncode == 0, done.stderr
    return path


def test_run_on_threads_is_the_sweep(study: pathlib.Path) -> None:
    out = study.parent / "threads"
    table = kanedyn.Study(study).run(out=out, threads=2)
    assert without_wall(out / "results.csv") == without_wall(study.parent / "sweep" / "results.csv")
    same_trajectories(out, study.parent / "sweep")
    assert len(table) == 40
    assert list(table["run"]) == list(range(40))
    assert set(table["status"]) == {"ok"}
    # The table holds the file's numbers (shortest round-trip decimals: the same doubles).
    lines = (out / "results.csv").read_text().splitlines()
    assert float(lines[8].split(",")[4]) == table["final:head.z"][7]


def test_a_dict_is_the_file(study: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import yaml  # noqa: PLC0415

    monkeypatch.chdir(study.parent)
    from_dict = kanedyn.Study(yaml.safe_load(study.read_text()))
    from_file = kanedyn.Study(study)
    assert from_dict.columns == from_file.columns
    assert [from_dict.parameters(i) for i in range(40)] == [from_file.parameters(i) for i in range(40)]


def test_refusals_are_located(tmp_path: pathlib.Path) -> None:
    path = make_study(tmp_path, 2, 0.1)
    path.write_text(path.read_text().replace("forces[1].stiffness", "forces[1].stifness"))
    with pytest.raises(kanedyn.ModelError) as e:
        kanedyn.Study(path)
    assert e.value.file == str(path)
    assert (e.value.line, e.value.column) == (8, 10)
    assert e.value.key_path == "vary[1].key"
    assert "closest: 'stiffness'" in e.value.problem


@pytest.fixture
def client_one() -> Iterator[object]:
    with distributed.LocalCluster(
        host="127.0.0.1", processes=True, n_workers=1, threads_per_worker=1, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        yield client


def test_dask_one_worker_is_the_sweep(study: pathlib.Path, client_one: object) -> None:
    out = study.parent / "dask1"
    kanedyn.Study(study).run(out=out, client=client_one, chunk_size=7)
    assert without_wall(out / "results.csv") == without_wall(study.parent / "sweep" / "results.csv")
    same_trajectories(out, study.parent / "sweep")


class CountingClient:
    """A client whose submit counts the chunks on the cluster at once."""

    def __init__(self, client: object) -> None:
        self._client = client
        self.outstanding = 0
        self.most = 0
        self.submitted = 0

    def nthreads(self) -> object:
        return self._client.nthreads()  # type: ignore[attr-defined]

    def cancel(self, futures: object) -> object:
        return self._client.cancel(futures)  # type: ignore[attr-defined]

    def submit(self, *args: object, **kwargs: object) -> object:
        future = self._client.submit(*args, **kwargs)  # type: ignore[attr-defined]
        self.outstanding += 1
        self.submitted += 1
        self.most = max(self.most, self.outstanding)

        def done(_: object) -> None:
            self.outstanding -= 1

        future.add_done_callback(done)
        return future


def test_dask_keeps_a_bounded_number_of_chunks_in_flight(study: pathlib.Path, client_one: object) -> None:
    # 40 runs in chunks of 2 on one thread: 20 chunks, at most 4 on the cluster at once, so the
    # caller's memory does not grow with the study's runs (submitting all at once, as before,
    # had about 20 out). One more is allowed: a chunk's done callback may run just after the
    # loop has taken its result and submitted the next.
    counting = CountingClient(client_one)
    out = study.parent / "dask_bounded"
    kanedyn.Study(study).run(out=out, client=counting, chunk_size=2)
    assert counting.submitted == 20
    assert 1 <= counting.most <= 5
    assert without_wall(out / "results.csv") == without_wall(study.parent / "sweep" / "results.csv")


class Cluster:
    """A scheduler and worker processes on 127.0.0.1, started as a user starts them on
    machines (`dask scheduler`, `dask worker`), each worker in one process (no nanny) so that a
    test can kill it."""

    def __init__(self, folder: pathlib.Path, workers: int):
        self.scheduler_file = str(folder / "scheduler.json")
        env = dict(os.environ)
        self.logs = open(folder / "cluster.log", "w")  # noqa: SIM115 (closed in stop)
        self.scheduler = subprocess.Popen(
            [PYTHON, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
             "--dashboard-address", ":0", "--scheduler-file", self.scheduler_file],
            env=env, stdout=self.logs, stderr=self.logs,
        )  # fmt: skip
        self.workers = [
            subprocess.Popen(
                [PYTHON, "-m", "distributed.cli.dask_worker", "--scheduler-file",
                 self.scheduler_file, "--no-nanny", "--nthreads", "1", "--host", "127.0.0.1",
                 "--no-dashboard", "--death-timeout", "30"],
                env=env, stdout=self.logs, stderr=self.logs,
            )  # fmt: skip
            for _ in range(workers)
        ]

    def client(self, workers: int) -> object:
        for _ in range(300):
            if os.path.exists(self.scheduler_file):
                break
            time.sleep(0.1)
        client = distributed.Client(scheduler_file=self.scheduler_file, timeout=30)
        client.wait_for_workers(workers, timeout=60)
        return client

    def stop(self) -> None:
        for p in [*self.workers, self.scheduler]:
            if p.poll() is None:
                p.terminate()
        for p in [*self.workers, self.scheduler]:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.logs.close()


@pytest.fixture
def cluster3(tmp_path: pathlib.Path) -> Iterator[Cluster]:
    cluster = Cluster(tmp_path, 3)
    try:
        yield cluster
    finally:
        cluster.stop()


def test_dask_three_workers_one_killed_is_the_sweep(tmp_path: pathlib.Path, cluster3: Cluster) -> None:
    # 400 runs of 1 s in chunks of 8: a few seconds on three workers, so that one is killed
    # while it holds chunks.
    path = make_study(tmp_path / "s", 200, 1.0)
    done = run_tool(["sweep", path, "-o", path.parent / "sweep", "-j", "2"])
    assert done.returncode == 0, done.stderr
    client = cluster3.client(3)
    try:
        pids = client.run(os.getpid)
        errors: List[BaseException] = []

        def run() -> None:
            try:
                kanedyn.Study(path).run(out=path.parent / "dask3", client=client, chunk_size=8)
            except BaseException as e:  # noqa: BLE001 (reported below)
                errors.append(e)

        thread = threading.Thread(target=run)
        thread.start()
        killed = None
        deadline = time.monotonic() + 60
        while killed is None and time.monotonic() < deadline and thread.is_alive():
            for address, tasks in client.processing().items():
                if tasks and address in pids:
                    os.kill(pids[address], signal.SIGKILL)
                    killed = address
                    break
            time.sleep(0.05)
        thread.join(timeout=120)
        assert killed is not None, "no worker held a chunk"
        assert not thread.is_alive()
        assert not errors, errors
        assert len(client.scheduler_info()["workers"]) == 2
    finally:
        client.close()
    assert without_wall(path.parent / "dask3" / "results.csv") == without_wall(path.parent / "sweep" / "results.csv")
    same_trajectories(path.parent / "dask3", path.parent / "sweep")


DRIVER = """
import sys, distributed, kanedyn
client = distributed.Client(scheduler_file=sys.argv[1], timeout=30)
kanedyn.Study(sys.argv[2]).run(out=sys.argv[3], client=client, chunk_size=4)
print("finished")
"""


def test_dask_driver_killed_and_started_again_resumes(tmp_path: pathlib.Path, cluster3: Cluster) -> None:
    # 800 runs of 1.5 s: some seconds on two cores, so that the kill comes before the end.
    path = make_study(tmp_path / "s", 400, 1.5)
    done = run_tool(["sweep", path, "-o", path.parent / "sweep", "-j", "2"])
    assert done.returncode == 0, done.stderr
    cluster3.client(3).close()
    out = path.parent / "dask"
    args = [PYTHON, "-c", DRIVER, cluster3.scheduler_file, str(path), str(out)]
    driver = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while not (out / "manifest" / "part_000001.csv").exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert (out / "manifest" / "part_000001.csv").exists()
    finally:
        driver.kill()
        driver.wait()
    assert not (out / "results.csv").exists()
    kept = len(list((out / "manifest").glob("part_*.csv")))
    assert kept >= 1
    again = subprocess.run(args, capture_output=True, text=True, timeout=120, check=False)
    assert again.returncode == 0, again.stderr
    assert again.stdout.strip() == "finished"
    assert without_wall(out / "results.csv") == without_wall(path.parent / "sweep" / "results.csv")
    same_trajectories(out, path.parent / "sweep")


def test_every_run_failing(tmp_path: pathlib.Path) -> None:
    path = make_study(tmp_path, 1, 0.1)
    path.write_text(path.read_text().replace("grid: [4.0, 6.0]", "grid: [-4.0, 0.0]"))
    table = kanedyn.Study(path).run(out=tmp_path / "out")
    assert len(table) == 2
    assert all(s.startswith("invalid model: eight_body.yaml:") for s in table["status"])
    assert np.isnan(np.asarray(table["final:head.z"], dtype=float)).all()


@pytest.mark.parametrize(
    "study, plot, output",
    [
        ("tennis_flip.yaml", "plot_tennis_flip.py", "tennis_flip.png"),
        ("eight_body_stiffness.yaml", "plot_eight_body_stiffness.py", "eight_body_stiffness.png"),
    ],
)
def test_example_studies_run_and_plot(tmp_path: pathlib.Path, study: str, plot: str, output: str) -> None:
    pytest.importorskip("matplotlib")
    examples = EXAMPLES / "studies"
    done = run_tool(["sweep", examples / study, "-o", tmp_path / "out"])
    assert done.returncode == 0, done.stderr
    assert "failed: 0" in done.stdout
    drawn = subprocess.run([PYTHON, examples / plot, tmp_path / "out"], capture_output=True, text=True, check=False)
    assert drawn.returncode == 0, drawn.stderr
    assert (tmp_path / "out" / output).stat().st_size > 10000


THREADED_DRIVER = """
import sys, kanedyn
kanedyn.Study(sys.argv[1]).run(out=sys.argv[2], threads=1)
print("finished")
"""


def test_ctrl_c_keeps_the_runs_done_and_run_again_resumes(tmp_path: pathlib.Path) -> None:
    # 600 runs of 2 s: about 3 s on one thread; Ctrl-C comes after the first second.
    path = make_study(tmp_path, 300, 2.0)
    out = tmp_path / "out"
    args = [PYTHON, "-c", THREADED_DRIVER, str(path), str(out)]
    driver = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (out / "manifest" / "part_000001.csv").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    sent = time.monotonic()
    driver.send_signal(signal.SIGINT)
    _, err = driver.communicate(timeout=60)
    assert time.monotonic() - sent < 1.5
    assert driver.returncode != 0
    assert "KeyboardInterrupt: stopped:" in err
    assert "run() again with the same folder" in err
    assert not (out / "results.csv").exists()
    again = subprocess.run(args, capture_output=True, text=True, timeout=120, check=False)
    assert again.returncode == 0, again.stderr
    done = run_tool(["sweep", path, "-o", tmp_path / "sweep", "-j", "2"])
    assert done.returncode == 0, done.stderr
    assert without_wall(out / "results.csv") == without_wall(tmp_path / "sweep" / "results.csv")
