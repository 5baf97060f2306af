"""Batch runs: manifest expansion and validation, failing items, resuming, a dying Dask worker,
identical tables from every backend (serial, local processes, a Dask LocalCluster), and an
unreachable scheduler."""

from __future__ import annotations

import csv
import os
import signal
import socket
import time

import pytest
import yaml

from avtrack.cli.batch import (
    MARKER,
    expand_manifest,
    item_folder,
    load_manifest,
    run_items,
)
from avtrack.cli.batch import runner as batch_runner
from avtrack.cli.batch.runner import materialise
from avtrack.cli.main import main
from avtrack.errors import InputError


def _without_time(rows):
    return [{k: v for k, v in r.items() if k != "seconds"} for r in rows]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """Two tiny simulated scenes, drawn once: video detections (3 s) and audio (2 s)."""
    root = tmp_path_factory.mktemp("scenes")
    return {"video": materialise("walkout:0:3", root), "audio": materialise("walkout:2:2", root)}


@pytest.fixture(scope="module")
def manifest(scenes, tmp_path_factory):
    """Good items and one corrupt recording among them."""
    folder = tmp_path_factory.mktemp("manifest")
    (folder / "broken.wav").write_bytes(b"RIFF\x00\x00not audio at all")
    raw = {
        "name": "tiny",
        "items": [
            {"command": "track-mot", "input": str(scenes["video"]),
             "params": {"birth_frames": [2, 3]}},
            {"id": "broken", "command": "localize", "audio": "broken.wav",
             "array": str(scenes["audio"] / "array.json")},
            {"command": "localize", "input": str(scenes["audio"]),
             "params": {"method": "srp-phat"}},
            {"command": "track-audio", "audio": str(scenes["audio"] / "audio.wav"),
             "array": str(scenes["audio"] / "array.json"),
             "gt": str(scenes["audio"] / "gt" / "doa.csv"), "params": {"tracker": "vonmises"}},
        ],
    }  # fmt: skip
    path = folder / "manifest.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.fixture(scope="module")
def serial(manifest, tmp_path_factory):
    _, items = load_manifest(manifest)
    out = tmp_path_factory.mktemp("serial")
    rows, reused = run_items(items, out)
    assert reused == 0
    return items, rows


# ------------------------------------------------------------------------------- manifests
def test_expansion_order_grid_and_stable_ids(manifest, scenes):
    name, items = load_manifest(manifest)
    assert name == "tiny" and len(items) == 5
    assert [i["params"] for i in items[:2]] == [{"birth_frames": 2}, {"birth_frames": 3}]
    assert items[2]["label"] == "broken" and items[2]["id"].startswith("localize_broken")
    assert items[4]["paths"]["gt"] == str(scenes["audio"] / "gt" / "doa.csv")
    assert [i["id"] for i in load_manifest(manifest)[1]] == [i["id"] for i in items]
    assert len({i["id"] for i in items}) == 5


def test_csv_manifest_with_a_grid(tmp_path, scenes):
    path = tmp_path / "m.csv"
    path.write_text(
        "id,command,audio,array,gt,param.tracker,param.step\n"
        f"a,track-audio,{scenes['audio']}/audio.wav,{scenes['audio']}/array.json,"
        f"{scenes['audio']}/gt/doa.csv,gauss;vonmises,4\n"
        f"b,localize,{scenes['audio']}/audio.wav,nao4,,,\n")
    name, items = load_manifest(path)
    assert name == "m" and len(items) == 3
    assert [i["params"] for i in items[:2]] == [{"tracker": "gauss", "step": 4},
                                                {"tracker": "vonmises", "step": 4}]
    assert items[2]["paths"]["array"] == "nao4" and items[2]["params"] == {}


@pytest.mark.parametrize(
    ("raw", "match"),
    [
        ({"items": []}, "items: expected a non-empty list"),
        ({"items": [{"command": "dance", "input": "walkout:0"}]}, r"items\[0\].command"),
        ({"items": [{"command": "localize"}]}, r"items\[0\].command: localize needs audio"),
        ({"items": [{"command": "localize", "input": "nowhere/x"}]},
         r"items\[0\].input: no such folder"),
        ({"items": [{"command": "localize", "inputs": ["walkout:x"]}]},
         r"items\[0\].inputs\[0\]: expected NAME:SEED"),
        ({"items": [{"command": "localize", "input": "walkout:0", "when": 1}]},
         r"items\[0\].when: unknown field"),
        ({"items": [{"command": "localize", "input": "walkout:0", "video": "v.mp4"}]},
         r"items\[0\].video: not an input of localize"),
        ({"items": [{"command": "localize", "input": "walkout:0", "audio": "gone.wav"}]},
         r"items\[0\].audio: no such file"),
        ({"items": [{"command": "localize", "input": "walkout:0",
                     "params": {"method": "guess"}}]}, r"items\[0\].params.method: expected one"),
        ({"items": [{"command": "localize", "input": "walkout:0", "params": {"output": 1}}]},
         r"items\[0\].params.output: set by the batch"),
        ({"items": [{"command": "track-mot", "input": "walkout:0"},
                    {"command": "track-mot", "input": "walkout:0"}]}, "given twice"),
        ({"jobs": []}, "jobs: unknown field"),
    ],
)  # fmt: skip
def test_bad_manifests_name_the_file_item_and_field(raw, match):
    with pytest.raises(InputError, match=match) as info:
        expand_manifest(raw, "manifest.yaml")
    assert str(info.value).startswith("manifest.yaml: ")


def test_bad_csv_manifest_names_the_row_and_column(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("command,input,param.method\nlocalize,walkout:0,srp-phat\n"
                    "localize,walkout:1,nope\n")
    with pytest.raises(InputError, match=r"m.csv, row 3: param.method: expected one of"):
        load_manifest(path)
    path.write_text("command,audoi\nlocalize,x.wav\n")
    with pytest.raises(InputError, match=r"m.csv, row 1: audoi: unknown column"):
        load_manifest(path)


def test_builtin_manifest_loads():
    name, items = load_manifest("smoke")
    assert name == "smoke" and len(items) == 8


# ------------------------------------------------------------------------ running, failing
def test_a_corrupt_item_is_reported_and_the_others_complete(serial):
    _, rows = serial
    assert [r["status"] for r in rows] == ["ok", "ok", "failed", "ok", "ok"]
    assert "broken.wav" in rows[2]["error"] and "\n" not in rows[2]["error"]
    assert all(0 < r["MOTA"] <= 100 for r in rows[:2])
    assert rows[3]["command"] == "localize" and 0 <= rows[3]["MD%"] <= 100  # the scene's gt
    assert rows[4]["OSPA"] >= 0 and "IDs" in rows[4]


def test_rerun_resumes_without_recomputing(manifest, tmp_path, monkeypatch):
    _, items = load_manifest(manifest)
    rows, _ = run_items(items, tmp_path)
    markers = {i: item_folder(tmp_path, it) / MARKER for i, it in enumerate(items)}
    mtimes = {i: m.stat().st_mtime_ns for i, m in markers.items() if m.exists()}
    assert sorted(mtimes) == [0, 1, 3, 4]
    # a folder killed half-way: outputs there, no marker
    markers[1].unlink()
    (markers[1].parent / "tracks.txt").write_text("half")
    runs = []
    real = batch_runner.run_cli
    monkeypatch.setattr(batch_runner, "run_cli", lambda argv: (runs.append(argv[0]),
                                                                real(argv))[1])
    again, reused = run_items(items, tmp_path)
    assert reused == 3 and runs == ["track-mot", "localize"]  # the half one, the failing one
    assert all(markers[i].stat().st_mtime_ns == mtimes[i] for i in (0, 3, 4))
    assert _without_time(again) == _without_time(rows)
    assert not list((tmp_path / "items").glob(".*"))


# -------------------------------------------------------------------------------- backends
def test_local_processes_give_identical_rows(serial, tmp_path):
    items, rows = serial
    assert _without_time(run_items(items, tmp_path, workers=2)[0]) == _without_time(rows)


def test_dask_local_cluster_gives_identical_rows(serial, tmp_path):
    distributed = pytest.importorskip("distributed")
    items, rows = serial
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        by_address = run_items(items, tmp_path / "a", scheduler=cluster.scheduler_address)[0]
    by_local = run_items(items[:2], tmp_path / "b", scheduler="local", workers=2)[0]
    assert _without_time(by_address) == _without_time(rows)
    assert _without_time(by_local) == _without_time(rows[:2])


def test_a_killed_dask_worker_does_not_stop_the_batch(serial, tmp_path):
    distributed = pytest.importorskip("distributed")
    items, rows = serial
    killed = []
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        pids = client.run(os.getpid)

        def kill_a_busy_worker(done, total):
            if killed or done < 1:
                return
            for _ in range(200):  # the worker that is running an item
                busy = [a for a, keys in client.processing().items() if keys and a in pids]
                if busy:
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    killed.append(busy[0])
                    return
                time.sleep(0.01)

        got, _ = run_items(items, tmp_path, scheduler=client, progress=kill_a_busy_worker)
    assert killed
    assert _without_time(got) == _without_time(rows)
    assert not list((tmp_path / "items").glob(".*"))


def test_unreachable_scheduler_is_reported_within_5_s(serial, tmp_path):
    pytest.importorskip("distributed")
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    items, _ = serial
    t0 = time.perf_counter()
    with pytest.raises(InputError, match=f"cannot reach the Dask scheduler tcp://127.0.0.1:{port}"):
        run_items(items[:1], tmp_path, scheduler=f"tcp://127.0.0.1:{port}")
    assert time.perf_counter() - t0 < 5


# ---------------------------------------------------------------------------------- the CLI
def test_cli_batch_writes_tables_and_resumes(manifest, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["batch", str(manifest), "-o", str(out), "-q"]) == 1  # one item failed
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert len(rows) == 5 and rows[3]["param.method"] == "srp-phat"
    assert [r["status"] for r in rows].count("failed") == 1
    assert "| localize |" in (out / "results.md").read_text()
    assert main(["bench", str(manifest), "-o", str(out)]) == 1  # the alias; resumes
    assert "(4 complete before, 1 failed)" in capsys.readouterr().out
    bad = tmp_path / "bad.yaml"
    bad.write_text("items: [{command: fly, input: x}]\n")
    assert main(["batch", str(bad), "-o", str(tmp_path / "o2")]) == 2
    assert "bad.yaml: items[0].command" in capsys.readouterr().err


def test_cli_unreachable_scheduler_exits_2(manifest, tmp_path, capsys):
    pytest.importorskip("distributed")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.perf_counter()
    code = main(["batch", str(manifest), "-o", str(tmp_path / "o"), "-q",
                 "--scheduler", f"tcp://127.0.0.1:{port}"])
    assert code == 2 and time.perf_counter() - t0 < 5
    assert "cannot reach the Dask scheduler" in capsys.readouterr().err
