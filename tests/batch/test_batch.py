"""Batch conversion: planning, verification, failures, resume, Dask, the command line."""

from __future__ import annotations

import csv
import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import need, smooth_volume

from volpack import api, batch
from volpack import io as vio
from volpack.cli import main

SHAPE = (20, 24, 28)


@pytest.fixture
def tree(tmp_path):
    """scans/{a/x.npy, a/b/y.nii.gz, c/w.npy, c/z.npy (float32)}; returns (root, arrays)."""
    root = tmp_path / "scans"
    arrays = {
        "a/x.npy": smooth_volume(SHAPE, np.int16, seed=1),
        "a/b/y.nii.gz": smooth_volume(SHAPE, np.int16, seed=2),
        "c/w.npy": smooth_volume(SHAPE, np.int16, seed=3),
        "c/z.npy": smooth_volume(SHAPE, np.int16, seed=4).astype(np.float32) / 7,
    }
    for rel, a in arrays.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        vio.write_volume(a, str(root / rel))
    return root, arrays


def rels(tasks, out):
    return sorted(os.path.relpath(t.output, out) for t in tasks)


def statuses(report):
    return {os.path.basename(f["output"]): f["status"] for f in report["files"]}


def cli(*args, code=0):
    r = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    assert r.exit_code == code, r.output
    return r


# -- planning --------------------------------------------------------------------------


def test_glob_and_folder_mirror_the_tree(tree, tmp_path):
    root, _ = tree
    out = tmp_path / "out"
    tasks = batch.plan(str(root / "**" / "*.npy"), str(out))
    assert rels(tasks, out) == ["a/x.vpk", "c/w.vpk", "c/z.vpk"]
    tasks = batch.plan(str(root), str(out))
    assert rels(tasks, out) == ["a/b/y.vpk", "a/x.vpk", "c/w.vpk", "c/z.vpk"]
    # a glob with an HDF5 dataset keeps the dataset; its root is the glob's fixed part
    (tmp_path / "run").mkdir()
    vio.write_volume(smooth_volume(SHAPE), str(tmp_path / "run" / "t1.h5:/T"))
    tasks = batch.plan(str(tmp_path / "run" / "*.h5:/T"), str(out))
    assert [t.input.endswith("t1.h5:/T") for t in tasks] == [True]
    assert rels(tasks, out) == ["t1.vpk"]


@pytest.mark.slow  # compiles the lossy float paths for one file of two
def test_zarr_store_in_a_folder_is_one_input(tree, tmp_path):
    zarr = pytest.importorskip("zarr")
    root, _ = tree
    a = smooth_volume(SHAPE, np.uint16, seed=5)
    zarr.create_array(str(root / "a" / "m.zarr"), shape=SHAPE, chunks=(8, 8, 8), dtype=a.dtype)[
        ...
    ] = a  # chunk files under it: not inputs of their own
    out = tmp_path / "out"
    tasks = batch.plan(str(root), str(out))
    assert rels(tasks, out) == ["a/b/y.vpk", "a/m.vpk", "a/x.vpk", "c/w.vpk", "c/z.vpk"]
    batch.run([t for t in tasks if t.input.endswith("m.zarr")], workers=1)
    np.testing.assert_array_equal(api.decompress(str(out / "a" / "m.vpk")).data, a)


def test_manifest_csv_with_per_file_options(tree, tmp_path):
    root, arrays = tree
    manifest = root / "manifest.csv"
    with open(manifest, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["input", "output", "max_error", "coder"])
        w.writerow(["a/x.npy", "", "2", "huffman"])
        w.writerow(["c/z.npy", "floats/z.vpk", "", ""])
    out = tmp_path / "out"
    tasks = batch.plan(str(manifest), str(out), options={"rel_error": 0.01})
    assert rels(tasks, out) == ["a/x.vpk", "floats/z.vpk"]
    assert tasks[0].options == {"max_error": 2.0, "coder": "huffman"}  # replaces rel_error
    assert tasks[1].options == {"rel_error": 0.01}
    report = batch.run(tasks)
    assert report["totals"]["ok"] == 2
    back = api.decompress(str(out / "a" / "x.vpk")).data
    assert np.abs(back.astype(int) - arrays["a/x.npy"]).max() <= 2
    assert api.info(str(out / "a" / "x.vpk"))["header"]["codec"]["coder"] == "huffman"


def test_same_input_twice_once_and_colliding_outputs_refused(tree, tmp_path):
    root, _ = tree
    x = str(root / "a" / "x.npy")
    tasks = batch.plan([x, x, str(root / "a" / "*.npy")], str(tmp_path / "out"))
    assert len(tasks) == 1
    vio.write_volume(smooth_volume(SHAPE), str(root / "a" / "x.nrrd"))
    with pytest.raises(batch.BatchError, match="would both be written"):
        batch.plan([x, str(root / "a" / "x.nrrd")], str(tmp_path / "out"))
    with pytest.raises(batch.BatchError, match="found none"):
        batch.plan(str(root / "*.tif"), str(tmp_path / "out"))


# -- running ---------------------------------------------------------------------------


def test_outputs_verified_lossless_and_within_bound(tree, tmp_path):
    root, arrays = tree
    out = tmp_path / "out"
    report = batch.run(batch.plan(str(root), str(out)), workers=2, executor="thread")
    assert report["totals"]["ok"] == 4 and report["totals"]["ratio"] > 1
    for rel, a in arrays.items():
        back = api.decompress(str(out / batch.strip_volume_ext(rel)) + ".vpk").data
        assert np.array_equal(back, a)
    lossy = tmp_path / "lossy"
    tasks = batch.plan(str(root), str(lossy), options={"max_error": 0.5}, verify="checksum")
    report = batch.run(tasks)
    assert report["totals"]["ok"] == 4
    for rel, a in arrays.items():
        back = api.decompress(str(lossy / batch.strip_volume_ext(rel)) + ".vpk").data
        assert np.abs(back.astype(np.float64) - a).max() <= 0.5
    f = report["files"][0]
    assert {"raw_nbytes", "nbytes", "ratio", "max_error", "psnr", "seconds"} <= set(f)
    # the check itself catches a voxel out of bound
    a = arrays["a/x.npy"]
    b = a.copy()
    b[3, 4, 5] += 2
    with pytest.raises(batch.VerifyError):
        batch.compare(a, b, {"lossless": False, "error_bound": 1.0})
    with pytest.raises(batch.VerifyError):
        batch.compare(a, b, {"lossless": True})


def test_corrupt_input_fails_alone_and_fail_fast_stops(tree, tmp_path):
    root, _ = tree
    (root / "c" / "bad.npy").write_bytes(b"not a volume at all")
    report = batch.run(batch.plan(str(root / "c"), str(tmp_path / "out")))
    assert statuses(report) == {"bad.vpk": "failed", "w.vpk": "ok", "z.vpk": "ok"}
    bad = report["files"][0]
    assert "npy" in bad["error"] and "\n" not in bad["error"]
    assert not (tmp_path / "out" / "bad.vpk").exists()
    assert report["totals"]["failed"] == 1 and report["totals"]["ok"] == 2

    report = batch.run(batch.plan(str(root / "c"), str(tmp_path / "ff")), fail_fast=True)
    assert statuses(report) == {"bad.vpk": "failed", "w.vpk": "cancelled", "z.vpk": "cancelled"}


def test_existing_outputs_and_unwritable_folder(tree, tmp_path):
    root, _ = tree
    out = tmp_path / "out"
    batch.run(batch.plan(str(root), str(out)))
    with pytest.raises(batch.BatchError, match="exist already"):
        batch.run(batch.plan(str(root), str(out)))
    assert batch.run(batch.plan(str(root), str(out)), force=True)["totals"]["ok"] == 4

    blocker = tmp_path / "file.txt"
    blocker.write_text("a file where a folder should be")
    bad_out = blocker / "out"
    with pytest.raises(batch.BatchError, match="cannot write to the output folder"):
        batch.run(batch.plan(str(root), str(bad_out)), journal=str(bad_out / batch.JOURNAL_NAME))
    assert sorted(os.listdir(tmp_path)) == ["file.txt", "out", "scans"]
    r = cli("-q", "batch", root, bad_out, code=1)
    assert r.stderr.startswith("volpack: error: cannot write") and r.stderr.count("\n") == 1


def test_memory_budget_limits_tasks_in_flight(tree, tmp_path):
    root, _ = tree
    lock, active, peak = threading.Lock(), [0], [0]

    def counted(task):
        with lock:
            active[0] += 1
            peak[0] = max(peak[0], active[0])
        try:
            return batch.convert_one(task)
        finally:
            with lock:
                active[0] -= 1

    tasks = batch.plan(str(root), str(tmp_path / "out"))
    assert all(batch.estimate_nbytes(t) >= 3 * np.prod(SHAPE) * 2 for t in tasks)
    report = batch.run(tasks, workers=2, executor="thread", memory_limit=1, func=counted)
    assert report["totals"]["ok"] == 4 and peak[0] == 1


# -- resume ----------------------------------------------------------------------------


def test_resume_redoes_exactly_the_missing_and_damaged(tree, tmp_path):
    root, _ = tree
    out = tmp_path / "out"
    journal = str(out / batch.JOURNAL_NAME)
    tasks = batch.plan(str(root), str(out), options={"max_error": 0.5})
    first = batch.run(tasks, journal=journal)
    assert first["totals"]["ok"] == 4
    before = {p: (out / p).read_bytes() for p in ("a/x.vpk", "c/w.vpk", "c/z.vpk")}
    (out / "a" / "x.vpk").unlink()
    with open(out / "c" / "w.vpk", "r+b") as f:
        f.truncate(100)
    report = batch.run(tasks, journal=journal, resume=True)
    assert statuses(report) == {
        "x.vpk": "ok",
        "y.vpk": "skipped",
        "w.vpk": "ok",
        "z.vpk": "skipped",
    }
    assert {p: (out / p).read_bytes() for p in before} == before
    again = batch.run(tasks, journal=journal, resume=True)  # resuming twice is harmless
    assert again["totals"]["skipped"] == 4 and again["totals"]["ok"] == 0
    assert again["totals"]["ratio"] == pytest.approx(first["totals"]["ratio"])
    # other options: nothing is taken as done
    other = batch.plan(str(root), str(out), options={"max_error": 1.0})
    assert batch.run(other, journal=journal, resume=True)["totals"]["ok"] == 4


def test_resume_after_an_interruption(tree, tmp_path):
    root, _ = tree
    out = tmp_path / "out"
    journal = out / batch.JOURNAL_NAME
    tasks = batch.plan(str(root), str(out))
    batch.run(tasks[:2], journal=str(journal))  # the first half, then "kill -9":
    with open(journal, "a") as f:
        f.write('{"output": "c/w.vpk", "status": "o')  # a torn last line
    (out / "c").mkdir()
    (out / "c" / ".volpack-abc123.part").write_bytes(b"half a file")  # an atomic temp file
    report = batch.run(tasks, journal=str(journal), resume=True)
    assert [f["status"] for f in report["files"]] == ["skipped", "skipped", "ok", "ok"]
    assert sorted(os.listdir(out / "c")) == ["w.vpk", "z.vpk"]
    lines = [json.loads(s) for s in journal.read_text().splitlines()[:2]]
    assert {"input", "output", "input_size", "input_mtime_ns", "output_sha256"} <= set(lines[0])
    assert lines[0]["output"] == os.path.relpath(tasks[0].output, out)
    assert lines[0]["status"] == "ok"


# -- Dask ------------------------------------------------------------------------------


def test_dask_local_cluster_gives_the_same_bytes(tree, tmp_path):
    root, _ = tree
    opts = {"max_error": 0.5}
    here = batch.run(batch.plan(str(root), str(tmp_path / "here"), options=opts))
    tasks = batch.plan(str(root), str(tmp_path / "dask"), options=opts)
    there = batch.run(tasks, scheduler="local", workers=2, dask_processes=False)
    assert there["executor"].startswith("dask") and there["totals"]["ok"] == 4
    for a, b in zip(here["files"], there["files"]):
        assert Path(a["output"]).read_bytes() == Path(b["output"]).read_bytes()


def die_once(task):
    """Kill this worker process the first time it sees x.npy (a marker file remembers)."""
    marker = task.input + ".killed"
    if task.input.endswith("x.npy") and not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    return batch.convert_one(task)


@pytest.mark.slow  # a Dask cluster and a killed worker process
def test_dask_worker_killed_mid_task_is_retried(tree, tmp_path):
    need("distributed", "dask")
    from distributed import Client, LocalCluster

    root, _ = tree
    tasks = batch.plan(str(root / "a"), str(tmp_path / "out"))
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as cluster,
        Client(cluster) as client,
    ):
        report = batch.run(tasks, scheduler=client, func=die_once)
    assert os.path.exists(str(root / "a" / "x.npy") + ".killed")
    assert report["totals"]["ok"] == 2, report["files"]


# -- command line ----------------------------------------------------------------------


def test_cli_batch_report_resume_and_decompress_batch(tree, tmp_path):
    root, arrays = tree
    (root / "c" / "bad.npy").write_bytes(b"junk")
    out, rep = tmp_path / "out", tmp_path / "report.json"
    r = cli("-q", "batch", root / "**" / "*.np*", out, "--max-error", "0.5", "-j", "2",
            "--report", rep, code=1)  # fmt: skip
    assert "volpack: failed:" in r.stderr and "bad.npy" in r.stderr
    assert r.stderr.splitlines()[-1].startswith("volpack: error: ")
    report = json.loads(rep.read_text())
    assert report["totals"]["ok"] == 3 and report["totals"]["failed"] == 1
    vio.write_volume(smooth_volume(SHAPE), str(root / "c" / "bad.npy"), force=True)  # mended
    r = cli("batch", root / "**" / "*.np*", out, "--max-error", "0.5", "--resume", "--json")
    report = json.loads(r.stdout)
    assert report["totals"] == {**report["totals"], "ok": 1, "skipped": 3, "failed": 0}

    lossless = tmp_path / "lossless"
    cli("-q", "batch", root, lossless, "--coder", "huffman", "--brick", "16")
    back = tmp_path / "back"
    r = cli("-q", "decompress", lossless, back, "--batch", "--workers", "2")
    assert "5 ok" in r.stderr  # the four and the mended bad.npy
    for rel, a in arrays.items():
        assert np.array_equal(np.load(back / (batch.strip_volume_ext(rel) + ".npy")), a)
    cli("-q", "decompress", lossless, tmp_path / "nii", "--batch", "--format", "nii.gz")
    assert (tmp_path / "nii" / "a" / "b" / "y.nii.gz").exists()
    cli("-q", "decompress", lossless, tmp_path / "maps", "--batch", "--format", "mrc")
    assert np.array_equal(
        vio.read_volume(str(tmp_path / "maps" / "c" / "z.mrc")).data, arrays["c/z.npy"]
    )
    r = cli("-q", "decompress", lossless, back, "--batch", code=1)
    assert "exist already" in r.stderr


def test_cli_batch_help():
    r = cli("batch", "--help")
    for opt in ("--max-error", "--coder", "--scheduler", "--resume", "--verify", "--report"):
        assert opt in r.output


@pytest.mark.slow
def test_dask_scheduler_and_worker_processes_with_one_worker_killed(tree, tmp_path):
    """A real deployment: 'dask scheduler' and two 'dask worker' processes on 127.0.0.1
    (no nanny, so a dead worker stays dead); one worker dies in the middle of a task and
    the batch still finishes on the other, with the bytes a local run gives."""
    need("distributed", "dask")
    import subprocess
    import sys
    import time

    from distributed import Client

    root, _ = tree
    here = batch.run(batch.plan(str(root / "a"), str(tmp_path / "here")))
    tasks = batch.plan(str(root / "a"), str(tmp_path / "out"))
    env = dict(os.environ)  # the workers unpickle die_once from this file
    folder = Path(__file__).parent  # this file (die_once) and tests/ (conftest) for the workers
    env["PYTHONPATH"] = os.pathsep.join(
        [str(folder), str(folder.parent), env.get("PYTHONPATH", "")]
    )
    sched_file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "dask"]
    common = ["--no-dashboard"]
    procs = [
        subprocess.Popen(
            [
                *dask,
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--scheduler-file",
                str(sched_file),
                *common,
            ],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )  # fmt: skip
    ]
    try:
        t = time.monotonic()
        while not sched_file.exists() and time.monotonic() - t < 120:
            time.sleep(0.2)
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        *dask,
                        "worker",
                        "--scheduler-file",
                        str(sched_file),
                        "--host",
                        "127.0.0.1",
                        "--nthreads",
                        "1",
                        "--no-nanny",
                        *common,
                    ],
                    env=env,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )  # fmt: skip
            )
        with Client(scheduler_file=str(sched_file), timeout=120) as client:
            client.wait_for_workers(2, timeout=120)
            report = batch.run(tasks, scheduler=client, func=die_once)
            assert len(client.scheduler_info()["workers"]) == 1  # the killed one stayed dead
        dead = [p for p in procs[1:] if p.poll() is not None]
        assert len(dead) == 1
    finally:
        for p in procs:
            p.kill()
            p.wait()
    assert os.path.exists(str(root / "a" / "x.npy") + ".killed")
    assert report["totals"]["ok"] == 2, report["files"]
    for a, b in zip(here["files"], report["files"]):
        assert Path(a["output"]).read_bytes() == Path(b["output"]).read_bytes()


def test_batch_says_what_it_left_out(tree, tmp_path):
    root, _ = tree
    (root / "c" / "mesh.vtu").write_text("<VTKFile/>")
    (root / "c" / "notes.txt").write_text("scanner notes")
    (root / "c" / "old.vpk").write_bytes(b"")
    (root / "c" / ".hidden.npy").write_bytes(b"")
    skipped: list = []
    tasks = batch.plan(str(root), str(tmp_path / "out"), skipped=skipped)
    assert len(tasks) == 4
    why = {os.path.basename(p): w for p, w in skipped}
    assert set(why) == {"mesh.vtu", "notes.txt", "old.vpk"}
    assert why["mesh.vtu"].startswith("a mesh") and why["old.vpk"] == "already a .vpk"
    r = cli("-q", "batch", root, tmp_path / "out2")
    assert "left out 3 file(s)" in r.stderr and "notes.txt: not a volume format" in r.stderr
