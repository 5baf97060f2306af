"""Tests of avtrack.metrics.mot: parity with TrackEval's own evaluator, hand-computed cases,
invariants, and input validation."""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avtrack.io.mot import MOTData, read_mot
from avtrack.metrics.mot import MOTScores, box_iou, evaluate_mot, format_table

# --------------------------------------------------------------------------- helpers


def mot(rows: list[tuple], n_extra: int = 3) -> MOTData:
    """MOTData from ``(frame, id, left, top, width, height[, col7[, col8...]])`` tuples."""
    if not rows:
        return MOTData(np.zeros(0), np.zeros(0), np.zeros((0, 4)), np.zeros(0))
    width = 7 + n_extra
    arr = np.full((len(rows), width), -1.0)
    arr[:, 6] = 1.0
    for i, r in enumerate(rows):
        arr[i, : len(r)] = r
    arr = arr[np.argsort(arr[:, 0], kind="stable")]
    return MOTData(arr[:, 0], arr[:, 1], arr[:, 2:6], arr[:, 6], arr[:, 7:])


def to_text(rows: list[tuple], n_cols: int = 10) -> str:
    lines = []
    for r in rows:
        vals = [*r] + [1.0] * (7 - len(r)) + [-1.0] * (n_cols - max(len(r), 7))
        lines.append(
            ",".join(repr(float(v)) if i >= 2 else str(int(v)) for i, v in enumerate(vals))
        )
    return "\n".join(lines) + ("\n" if lines else "")


def trackeval_reference(
    tmp_path: Path, gt_text: str, res_text: str, n_frames: int, benchmark: str = "MOT15"
) -> dict[str, float | int]:
    """Scores from TrackEval's own Evaluator + MotChallenge2DBox on a MOTChallenge layout."""
    import trackeval

    seq = "SEQ-01"
    gt_dir = tmp_path / "gt" / f"{benchmark}-train" / seq
    (gt_dir / "gt").mkdir(parents=True)
    (gt_dir / "gt" / "gt.txt").write_text(gt_text)
    (gt_dir / "seqinfo.ini").write_text(f"[Sequence]\nname={seq}\nseqLength={n_frames}\n")
    res_dir = tmp_path / "trackers" / f"{benchmark}-train" / "perturbed" / "data"
    res_dir.mkdir(parents=True)
    (res_dir / f"{seq}.txt").write_text(res_text)
    seqmap = tmp_path / "seqmap.txt"
    seqmap.write_text(f"name\n{seq}\n")

    eval_config = trackeval.Evaluator.get_default_eval_config()
    eval_config.update(
        USE_PARALLEL=False,
        PRINT_RESULTS=False,
        PRINT_CONFIG=False,
        TIME_PROGRESS=False,
        OUTPUT_SUMMARY=False,
        OUTPUT_DETAILED=False,
        PLOT_CURVES=False,
        LOG_ON_ERROR=None,
    )
    ds_config = trackeval.datasets.MotChallenge2DBox.get_default_dataset_config()
    ds_config.update(
        GT_FOLDER=str(tmp_path / "gt"),
        TRACKERS_FOLDER=str(tmp_path / "trackers"),
        OUTPUT_FOLDER=str(tmp_path / "out"),
        BENCHMARK=benchmark,
        SPLIT_TO_EVAL="train",
        SEQMAP_FILE=str(seqmap),
        TRACKERS_TO_EVAL=["perturbed"],
        PRINT_CONFIG=False,
    )
    metric_config = {"THRESHOLD": 0.5, "PRINT_CONFIG": False}
    with contextlib.redirect_stdout(io.StringIO()):
        out, _ = trackeval.Evaluator(eval_config).evaluate(
            [trackeval.datasets.MotChallenge2DBox(ds_config)],
            [
                trackeval.metrics.CLEAR(dict(metric_config)),
                trackeval.metrics.Identity(dict(metric_config)),
                trackeval.metrics.HOTA(),
            ],
        )
    r = out["MotChallenge2DBox"]["perturbed"][seq]["pedestrian"]
    c, i, h = r["CLEAR"], r["Identity"], r["HOTA"]
    return {
        "MOTA": 100 * c["MOTA"],
        "MOTP": 100 * c["MOTP"],
        "IDF1": 100 * i["IDF1"],
        "HOTA": 100 * np.mean(h["HOTA"]),
        "FP": c["CLR_FP"],
        "FN": c["CLR_FN"],
        "IDSW": c["IDSW"],
        "Frag": c["Frag"],
        "MT": c["MT"],
        "PT": c["PT"],
        "ML": c["ML"],
        "IDP": 100 * i["IDP"],
        "IDR": 100 * i["IDR"],
        "DetA": 100 * np.mean(h["DetA"]),
        "AssA": 100 * np.mean(h["AssA"]),
        "n_gt_ids": r["Count"]["GT_IDs"],
        "n_frames": n_frames,
        "n_gt_dets": c["CLR_TP"] + c["CLR_FN"],
    }


def assert_scores_equal(ours: MOTScores, ref: dict[str, float | int], tol: float = 1e-9):
    got = ours.as_dict()
    assert set(got) == set(ref)
    for k, v in ref.items():
        assert got[k] == pytest.approx(float(v), abs=tol, rel=0), k


def perturb(gt: np.ndarray, seed: int, jitter: float, drop: float, n_fp: int) -> np.ndarray:
    """A deterministic imperfect "tracker result" made from ground-truth rows.

    Jitters boxes, drops rows, swaps the identities of two pairs of tracks halfway, splits a
    track in two, renumbers all ids sparsely, adds false positives, shuffles the row order.
    """
    rng = np.random.default_rng(seed)
    res = gt[gt[:, 6] != 0].copy()
    res = res[rng.random(len(res)) >= drop]
    res[:, 2:6] += rng.normal(0.0, jitter, (len(res), 4)) * res[:, 4:6].repeat(2, axis=1)
    res[:, 4:6] = np.maximum(res[:, 4:6], 1.0)
    ids = np.unique(res[:, 1]).astype(int)
    half = int(np.median(res[:, 0]))
    later = res[:, 0] > half
    for a, b in (ids[:2], ids[2:4]):  # identity swaps
        ia, ib = later & (res[:, 1] == a), later & (res[:, 1] == b)
        res[ia, 1], res[ib, 1] = b, a
    res[(res[:, 1] == ids[-1]) & (res[:, 0] > half + 5), 1] = ids.max() + 1  # a split track
    remap = {int(i): 7 * k + 3 for k, i in enumerate(rng.permutation(np.unique(res[:, 1])))}
    res[:, 1] = [remap[int(i)] for i in res[:, 1]]
    n_frames = int(gt[:, 0].max())
    fp = np.column_stack(
        [
            rng.integers(1, n_frames + 1, n_fp),
            1000 + np.arange(n_fp),
            rng.uniform(0, 500, n_fp),
            rng.uniform(0, 300, n_fp),
            rng.uniform(20, 120, (n_fp, 2)),
        ]
    )
    res = np.vstack([res[:, :6], fp])
    res = res[rng.permutation(len(res))]
    conf = rng.uniform(0.3, 1.0, (len(res), 1))
    return np.hstack([res, conf, -np.ones((len(res), 3))])


def rows_of(arr: np.ndarray) -> list[tuple]:
    return [tuple(r) for r in arr]


# --------------------------------------------------------------------------- parity


@pytest.fixture(scope="module")
def tud_gt_path(shared_data: Path) -> Path:
    path = shared_data / "mot15" / "TUD-Campus" / "gt" / "gt.txt"
    if not path.is_file():
        pytest.skip(f"../shared/data not found: {path} is missing")
    return path


@pytest.mark.parametrize(
    ("seed", "jitter", "drop", "n_fp"),
    [(0, 0.05, 0.10, 10), (1, 0.12, 0.30, 40), (2, 0.02, 0.0, 0), (3, 0.25, 0.5, 80)],
)
def test_parity_with_trackeval_on_tud_campus(tud_gt_path, tmp_path, seed, jitter, drop, n_fp):
    gt_arr = np.loadtxt(tud_gt_path, delimiter=",", ndmin=2)
    res_arr = perturb(gt_arr, seed, jitter, drop, n_fp)
    res_path = tmp_path / "res.txt"
    res_path.write_text(to_text(rows_of(res_arr)))
    n_frames = int(gt_arr[:, 0].max())
    ref = trackeval_reference(
        tmp_path, tud_gt_path.read_text(), res_path.read_text(), n_frames, "MOT15"
    )
    ours = evaluate_mot(
        read_mot(tud_gt_path, kind="gt"),
        read_mot(res_path, kind="result"),
        benchmark="MOT15",
        n_frames=n_frames,
    )
    assert_scores_equal(ours, ref)
    assert ours.MOTA < 100 and ours.IDSW > 0  # a non-trivial case


def test_parity_tud_campus_perfect_result(tud_gt_path):
    gt = read_mot(tud_gt_path, kind="gt")
    s = evaluate_mot(gt, gt)
    assert (s.MOTA, s.IDF1, s.HOTA, s.FP, s.FN, s.IDSW) == (100.0, 100.0, 100.0, 0, 0, 0)


def synthetic_mot17(seed: int) -> tuple[np.ndarray, np.ndarray, int]:
    """A 30-frame scene with pedestrians, distractor classes and zero-flagged rows (MOT17 gt
    columns: frame, id, box, flag, class, visibility), and a perturbed result."""
    rng = np.random.default_rng(seed)
    n_frames, rows = 30, []
    classes = [1, 1, 1, 1, 2, 7, 8, 12, 6, 3, 1, 1]
    for tid, cls in enumerate(classes, start=1):
        start, stop = sorted(rng.integers(1, n_frames + 1, 2))
        x, y = rng.uniform(0, 400), rng.uniform(0, 200)
        vx, vy = rng.normal(0, 4, 2)
        w, h = rng.uniform(30, 60), rng.uniform(60, 150)
        for f in range(start, stop + 1):
            flag = 0.0 if rng.random() < 0.1 else 1.0
            rows.append((f, tid, x + vx * f, y + vy * f, w, h, flag, cls, rng.uniform(0, 1)))
    gt = np.array(rows)
    gt = gt[np.lexsort((gt[:, 1], gt[:, 0]))]
    res = perturb(np.column_stack([gt[:, :6], np.ones(len(gt))]), seed, 0.08, 0.15, 15)
    return gt, res, n_frames


@pytest.mark.parametrize("bench", ["MOT16", "MOT17", "MOT20", "MOT15"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_parity_with_trackeval_distractor_preprocessing(tmp_path, bench, seed):
    gt_arr, res_arr, n_frames = synthetic_mot17(seed)
    gt_text, res_text = to_text(rows_of(gt_arr), 9), to_text(rows_of(res_arr))
    (tmp_path / "gt.txt").write_text(gt_text)
    (tmp_path / "res.txt").write_text(res_text)
    ref = trackeval_reference(tmp_path, gt_text, res_text, n_frames, bench)
    ours = evaluate_mot(
        read_mot(tmp_path / "gt.txt", kind="gt"),
        read_mot(tmp_path / "res.txt", kind="result"),
        benchmark=bench,
        n_frames=n_frames,
    )
    assert_scores_equal(ours, ref)


def test_parity_empty_result(tmp_path):
    gt_arr, _, n_frames = synthetic_mot17(0)
    gt_text = to_text(rows_of(gt_arr), 9)
    (tmp_path / "gt.txt").write_text(gt_text)
    (tmp_path / "res.txt").write_text("")
    ref = trackeval_reference(tmp_path, gt_text, "", n_frames, "MOT17")
    ours = evaluate_mot(
        read_mot(tmp_path / "gt.txt", kind="gt"),
        read_mot(tmp_path / "res.txt", kind="result"),
        benchmark="MOT17",
        n_frames=n_frames,
    )
    assert_scores_equal(ours, ref)
    assert ours.FP == 0 and ours.MOTA == 0.0 and ours.ML == ours.n_gt_ids


def test_box_iou_matches_trackeval():
    from trackeval.datasets._base_dataset import _BaseDataset

    rng = np.random.default_rng(0)
    a = np.column_stack([rng.uniform(0, 50, (7, 2)), rng.uniform(1, 40, (7, 2))])
    b = np.column_stack([rng.uniform(0, 50, (5, 2)), rng.uniform(1, 40, (5, 2))])
    np.testing.assert_array_equal(box_iou(a, b), _BaseDataset._calculate_box_ious(a, b))
    assert box_iou(a, np.zeros((0, 4))).shape == (7, 0)


# --------------------------------------------------------------------------- hand-computed

BOX = (10.0, 20.0, 100.0, 100.0)


def test_perfect_result_two_frames():
    gt = mot([(1, 1, *BOX), (2, 1, *BOX)])
    s = evaluate_mot(gt, gt)
    assert (s.MOTA, s.MOTP, s.IDF1, s.HOTA) == (100.0, 100.0, 100.0, 100.0)
    assert (s.FP, s.FN, s.IDSW, s.Frag, s.MT, s.PT, s.ML) == (0, 0, 0, 0, 1, 0, 0)
    assert (s.n_gt_ids, s.n_frames) == (1, 2)


def test_one_false_positive():
    gt = mot([(1, 1, *BOX), (2, 1, *BOX)])
    res = mot([(1, 5, *BOX), (1, 6, 300, 300, 20, 20), (2, 5, *BOX)])
    s = evaluate_mot(gt, res)
    # MOTA = 1 - (FN + FP + IDSW) / n_gt = 1 - 1/2; IDF1 = 2 IDTP / (2 IDTP + IDFP + IDFN)
    assert (s.FP, s.FN, s.IDSW) == (1, 0, 0)
    assert s.MOTA == pytest.approx(50.0)
    assert s.IDF1 == pytest.approx(100 * 4 / 5)
    assert s.IDP == pytest.approx(100 * 2 / 3) and s.IDR == pytest.approx(100.0)


def test_identity_switch():
    gt = mot([(f, 1, *BOX) for f in range(1, 5)])
    res = mot([(1, 7, *BOX), (2, 7, *BOX), (3, 8, *BOX), (4, 8, *BOX)])
    s = evaluate_mot(gt, res)
    assert (s.IDSW, s.FP, s.FN, s.Frag) == (1, 0, 0, 0)
    assert s.MOTA == pytest.approx(75.0)  # 1 - 1/4
    assert s.IDF1 == pytest.approx(50.0)  # IDTP 2, IDFP 2, IDFN 2


def test_fragmentation_and_miss():
    gt = mot([(f, 1, *BOX) for f in range(1, 5)])
    res = mot([(1, 3, *BOX), (2, 3, *BOX), (3, 9, 300, 300, 20, 20), (4, 3, *BOX)])
    s = evaluate_mot(gt, res)
    assert (s.FN, s.FP, s.Frag, s.IDSW, s.MT, s.PT) == (1, 1, 1, 0, 0, 1)
    assert s.MOTA == pytest.approx(50.0)  # (TP - FP - IDSW) / n_gt = (3 - 1 - 0) / 4


def test_frame_without_result_boxes_does_not_fragment():
    # TrackEval quirk, kept for parity: a frame where the tracker reports nothing at all does
    # not interrupt the track for the Frag count (it is still a miss)
    gt = mot([(f, 1, *BOX) for f in range(1, 5)])
    res = mot([(1, 3, *BOX), (2, 3, *BOX), (4, 3, *BOX)])
    s = evaluate_mot(gt, res)
    assert (s.FN, s.FP, s.Frag, s.IDSW) == (1, 0, 0, 0)
    assert s.MOTA == pytest.approx(75.0)


def test_motp_and_hota_with_known_iou():
    # every match has IoU 0.72: HOTA's 19 thresholds 0.05..0.95 accept 14 of them
    gt = mot([(f, 1, 0, 0, 100, 100) for f in (1, 2, 3)])
    res = mot([(f, 4, 0, 0, 100, 72) for f in (1, 2, 3)])
    s = evaluate_mot(gt, res)
    assert s.MOTP == pytest.approx(72.0)
    assert s.MOTA == pytest.approx(100.0)
    assert s.HOTA == pytest.approx(100 * 14 / 19)
    assert s.DetA == pytest.approx(100 * 14 / 19) and s.AssA == pytest.approx(100 * 14 / 19)


def test_iou_below_half_is_not_a_match():
    gt = mot([(1, 1, 0, 0, 100, 100)])
    res = mot([(1, 1, 0, 0, 100, 40)])
    s = evaluate_mot(gt, res)
    assert (s.FP, s.FN) == (1, 1)
    assert s.MOTA == pytest.approx(-100.0)  # (TP - FP - IDSW) / n_gt = (0 - 1 - 0) / 1


def test_lower_threshold_accepts_a_smaller_overlap():
    # IoU 0.4: no match at MOTChallenge's 0.5, a match at the thesis's 0.1 (§4.7.5)
    gt = mot([(1, 1, 0, 0, 100, 100), (2, 1, 0, 0, 100, 100)])
    res = mot([(1, 1, 0, 0, 100, 40), (2, 1, 0, 0, 100, 40)])
    assert (evaluate_mot(gt, res).FP, evaluate_mot(gt, res).FN) == (2, 2)
    s = evaluate_mot(gt, res, threshold=0.1)
    assert (s.FP, s.FN, s.IDSW, s.n_gt_dets) == (0, 0, 0, 2)
    assert s.MOTA == pytest.approx(100.0) and s.IDF1 == pytest.approx(100.0)
    assert s.MOTP == pytest.approx(40.0)


def test_custom_similarity_replaces_iou():
    gt = mot([(1, 1, 0, 0, 10, 10), (1, 2, 500, 0, 10, 10)])
    res = mot([(1, 7, 300, 300, 10, 10), (1, 8, 500, 0, 10, 10)])

    def first_gt_matches_anything(gb, rb):
        sim = box_iou(gb, rb)
        sim[gb[:, 0] < 100] = 0.9
        return sim

    s = evaluate_mot(gt, res, similarity=first_gt_matches_anything)
    assert (s.FP, s.FN, s.n_gt_dets) == (0, 0, 2)
    with pytest.raises(ValueError, match=r"similarity must return shape \(2, 2\)"):
        evaluate_mot(gt, res, similarity=lambda g, r: np.zeros((1, 1)))
    with pytest.raises(ValueError, match=r"in \[0, 1\]"):
        evaluate_mot(gt, res, similarity=lambda g, r: np.full((2, 2), 2.0))
    with pytest.raises(ValueError, match="threshold must be in"):
        evaluate_mot(gt, res, threshold=0.0)


def test_empty_result_and_empty_gt():
    gt = mot([(1, 1, *BOX), (3, 2, *BOX)])
    s = evaluate_mot(gt, mot([]))
    assert (s.FN, s.FP, s.MOTA, s.ML, s.n_frames) == (2, 0, 0.0, 2, 3)
    s = evaluate_mot(mot([]), gt)
    assert (s.FN, s.FP, s.n_gt_ids) == (0, 2, 0)


def test_mot15_ignores_zero_flag_rows():
    gt = mot([(1, 1, *BOX), (1, 2, 300, 300, 50, 50, 0.0)])
    res = mot([(1, 1, *BOX)])
    s = evaluate_mot(gt, res)
    assert (s.FN, s.FP, s.n_gt_ids, s.MOTA) == (0, 0, 1, 100.0)


def test_mot17_distractors_are_not_false_positives():
    # col 8 = class: 1 pedestrian, 7 static person (distractor), 6 non-MOT vehicle
    gt = mot([(1, 1, *BOX, 1, 1), (1, 2, 300, 300, 50, 50, 1, 7), (1, 3, 0, 300, 80, 40, 0, 6)])
    res = mot([(1, 1, *BOX), (1, 2, 300, 300, 50, 50), (1, 3, 0, 300, 80, 40)])
    s17 = evaluate_mot(gt, res, benchmark="MOT17")
    assert (s17.n_gt_ids, s17.FN, s17.FP) == (1, 0, 1)  # the vehicle box is an FP in MOT17
    s20 = evaluate_mot(gt, res, benchmark="MOT20")
    assert (s20.n_gt_ids, s20.FN, s20.FP) == (1, 0, 0)  # ... and a distractor in MOT20
    s15 = evaluate_mot(gt, res, benchmark="MOT15")  # no classes: all flag-1 rows are targets
    assert (s15.n_gt_ids, s15.FN, s15.FP) == (2, 0, 1)


# --------------------------------------------------------------------------- invariants


@st.composite
def scenes(draw) -> tuple[list[tuple], list[tuple]]:
    n_frames = draw(st.integers(1, 6))
    n_tracks = draw(st.integers(0, 4))
    starts = [(draw(st.integers(0, 300)), draw(st.integers(0, 200))) for _ in range(n_tracks)]
    gt, res = [], []
    for f in range(1, n_frames + 1):
        present = [k for k in range(n_tracks) if draw(st.booleans())]
        for k in present:
            gt.append((f, k + 1, starts[k][0] + 3 * f, starts[k][1], 40, 90))
        n_res = draw(st.integers(0, len(present) + 1))
        ids = draw(st.lists(st.integers(0, 6), min_size=n_res, max_size=n_res, unique=True))
        for j, tid in enumerate(ids):
            if j < len(present):
                k = present[j]
                dx, dy = draw(st.integers(-15, 15)), draw(st.integers(-25, 25))
                res.append((f, tid, starts[k][0] + 3 * f + dx, starts[k][1] + dy, 40, 90))
            else:
                res.append((f, tid, draw(st.integers(0, 400)), draw(st.integers(0, 300)), 40, 90))
    return gt, res


@settings(max_examples=60, deadline=None)
@given(scene=scenes(), perm=st.permutations(range(10)), offset=st.integers(0, 1000))
def test_scores_invariant_to_relabelling_ids(scene, perm, offset):
    gt_rows, res_rows = scene
    base = evaluate_mot(mot(gt_rows), mot(res_rows))
    gt2 = [(r[0], perm[int(r[1])] + offset, *r[2:]) for r in gt_rows]
    res2 = [(r[0], 3 * perm[int(r[1])] + 1, *r[2:]) for r in res_rows]
    new = evaluate_mot(mot(gt2), mot(res2))
    for k, v in base.as_dict().items():
        assert getattr(new, k) == pytest.approx(v, abs=1e-9), k


@settings(max_examples=40, deadline=None)
@given(scene=scenes())
def test_score_ranges_and_count_identities(scene):
    gt_rows, res_rows = scene
    s = evaluate_mot(mot(gt_rows), mot(res_rows))
    for k in ("MOTP", "IDF1", "HOTA", "IDP", "IDR", "DetA", "AssA"):
        assert 0.0 <= getattr(s, k) <= 100.0 + 1e-9, k
    assert s.MOTA <= 100.0
    assert s.MT + s.PT + s.ML == s.n_gt_ids
    assert s.FN <= len(gt_rows) and s.FP <= len(res_rows)
    if gt_rows:  # MOTA = 1 - (FN + FP + IDSW) / n_gt
        assert s.MOTA == pytest.approx(100 * (1 - (s.FN + s.FP + s.IDSW) / len(gt_rows)))
    perfect = evaluate_mot(mot(gt_rows), mot(gt_rows))
    assert perfect.FN == perfect.FP == perfect.IDSW == 0


# --------------------------------------------------------------------------- results API


def test_as_dict_is_json_serialisable_and_table_lists_columns():
    gt = mot([(1, 1, *BOX), (2, 1, *BOX)])
    s = evaluate_mot(gt, gt)
    d = json.loads(json.dumps(s.as_dict()))
    assert d["MOTA"] == 100.0 and d["FP"] == 0 and isinstance(d["IDSW"], int)
    table = format_table(s)
    for col in ("MOTA", "MOTP", "IDF1", "HOTA", "FP", "FN", "IDSW", "Frag", "MT", "ML"):
        assert col in table.splitlines()[0]
    md = format_table({"a": s, "b": s}, markdown=True)
    assert md.splitlines()[1].startswith("|---|") and len(md.splitlines()) == 4
    with pytest.raises(ValueError, match="unknown columns"):
        format_table(s, columns=("MOTA", "nope"))
    assert all(math.isfinite(v) for v in d.values())


def test_scores_are_frozen():
    s = evaluate_mot(mot([(1, 1, *BOX)]), mot([(1, 1, *BOX)]))
    with pytest.raises(AttributeError):
        s.MOTA = 0.0  # type: ignore[misc]


# --------------------------------------------------------------------------- bad input


def test_rejects_bad_arguments():
    gt = mot([(1, 1, *BOX), (2, 1, *BOX)])
    with pytest.raises(TypeError, match="gt must be MOTData"):
        evaluate_mot(np.zeros((2, 6)), gt)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="benchmark must be one of"):
        evaluate_mot(gt, gt, benchmark="MOT99")
    with pytest.raises(ValueError, match=r"n_frames must be >= the last frame in the data \(2\)"):
        evaluate_mot(gt, gt, n_frames=1)
    with pytest.raises(TypeError, match="n_frames must be an int"):
        evaluate_mot(gt, gt, n_frames=2.0)  # type: ignore[arg-type]


def test_rejects_bad_ids():
    gt = mot([(1, 1, *BOX), (2, 1, *BOX)])
    with pytest.raises(ValueError, match="res has id 4 more than once in frame 2"):
        evaluate_mot(gt, mot([(1, 4, *BOX), (2, 4, *BOX), (2, 4, 0, 0, 5, 5)]))
    with pytest.raises(ValueError, match="res ids must be >= 0, got -1 at frame 1"):
        evaluate_mot(gt, mot([(1, -1, *BOX)]))
    with pytest.raises(ValueError, match="gt has id 1 more than once in frame 1"):
        evaluate_mot(mot([(1, 1, *BOX), (1, 1, *BOX)]), gt)


def test_rejects_bad_classes():
    gt = mot([(1, 1, *BOX, 1, 1)])
    with pytest.raises(ValueError, match=r"res column 8 \(class\) must be 1"):
        evaluate_mot(gt, mot([(1, 1, *BOX, 0.9, 3)]))
    with pytest.raises(ValueError, match="needs a class in column 8"):
        evaluate_mot(mot([(1, 1, *BOX)], n_extra=0), gt, benchmark="MOT17")
    with pytest.raises(ValueError, match=r"gt column 8 \(class\) must be in 1..13, got 14"):
        evaluate_mot(mot([(1, 1, *BOX, 1, 14)]), gt, benchmark="MOT17")
