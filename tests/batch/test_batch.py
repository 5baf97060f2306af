"""Batch evaluation: suite expansion, and identical rows from every backend (serial, local
processes, a Dask LocalCluster of 2 workers)."""

from __future__ import annotations

import csv

import pytest
import yaml

from avtrack.batch import expand_suite, load_suite, run_items
from avtrack.cli.main import main
from avtrack.errors import InputError

SUITE = {
    "name": "tiny",
    "items": [
        {"task": "track-mot", "inputs": ["walkout:0:3", "walkout:1:3"],
         "params": {"birth_frames": [2, 3]}},
        {"task": "localize", "inputs": ["walkout:2:2"], "params": {"method": "srp-phat"}},
    ],
}  # fmt: skip


def _without_time(rows):
    return [{k: v for k, v in r.items() if k != "seconds"} for r in rows]


def test_expansion_order_and_grid():
    name, items = expand_suite(SUITE)
    assert name == "tiny" and len(items) == 5
    assert [(i["input"], i["params"]) for i in items[:4]] == [
        ("walkout:0:3", {"birth_frames": 2}),
        ("walkout:0:3", {"birth_frames": 3}),
        ("walkout:1:3", {"birth_frames": 2}),
        ("walkout:1:3", {"birth_frames": 3}),
    ]
    assert items[4]["params"] == {"method": "srp-phat"}


@pytest.mark.parametrize(
    ("raw", "match"),
    [
        ({"items": []}, "items: expected a non-empty list"),
        ({"items": [{"task": "dance", "inputs": ["walkout:0"]}]}, r"items\[0\].task"),
        ({"items": [{"task": "localize"}]}, r"items\[0\].inputs"),
        ({"items": [{"task": "localize", "inputs": ["nowhere/x"]}]}, "no such folder"),
        ({"items": [{"task": "localize", "inputs": ["walkout:x"]}]}, "NAME:SEED"),
        ({"items": [{"task": "localize", "inputs": ["walkout:0"], "when": 1}]}, "unknown field"),
        ({"jobs": []}, "jobs: unknown field"),
    ],
)
def test_bad_suites_name_the_field(raw, match):
    with pytest.raises(InputError, match=match):
        expand_suite(raw, "suite.yaml")


@pytest.fixture(scope="module")
def serial_rows():
    _, items = expand_suite(SUITE)
    return run_items(items)


def test_serial_rows_have_scores(serial_rows):
    assert len(serial_rows) == 5
    assert all(0 < r["MOTA"] <= 100 for r in serial_rows[:4])
    assert serial_rows[4]["task"] == "localize" and "MD%" in serial_rows[4]


def test_local_processes_give_identical_rows(serial_rows):
    _, items = expand_suite(SUITE)
    assert _without_time(run_items(items, workers=2)) == _without_time(serial_rows)


def test_dask_local_cluster_gives_identical_rows(serial_rows):
    distributed = pytest.importorskip("distributed")
    _, items = expand_suite(SUITE)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        rows = run_items(items, scheduler=client)
        by_address = run_items(items[:2], scheduler=cluster.scheduler_address)
    assert _without_time(rows) == _without_time(serial_rows)
    assert _without_time(by_address) == _without_time(serial_rows[:2])


def test_cli_bench_writes_tables(tmp_path, capsys):
    suite = tmp_path / "s.yaml"
    suite.write_text(yaml.safe_dump({"items": [SUITE["items"][1]]}))
    assert main(["bench", str(suite), "-o", str(tmp_path / "out")]) == 0
    rows = list(csv.DictReader((tmp_path / "out" / "results.csv").open()))
    assert len(rows) == 1 and rows[0]["param.method"] == "srp-phat"
    assert "| localize |" in (tmp_path / "out" / "results.md").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text("items: [{task: fly, inputs: [x]}]\n")
    assert main(["bench", str(bad), "-o", str(tmp_path / "o2")]) == 2
    assert "bad.yaml" in capsys.readouterr().err


def test_builtin_suite_loads():
    name, items = load_suite("smoke")
    assert name == "smoke" and len(items) == 8
