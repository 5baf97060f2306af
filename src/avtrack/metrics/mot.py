"""MOTChallenge scores (CLEAR-MOT, identity, HOTA) of a tracker result against ground truth.

The metrics themselves are TrackEval's (``trackeval.metrics.CLEAR``, ``Identity``, ``HOTA``);
this module only prepares one sequence the way TrackEval's ``MotChallenge2DBox`` dataset does
and reads the numbers back, so the scores equal those of the official evaluation kit (a parity
test in ``tests/metrics/test_mot.py`` checks this to 1e-9 on real data).

Preprocessing, as in ``MotChallenge2DBox.get_preprocessed_seq_data`` (TrackEval 1.3.0):

* every benchmark: ground-truth rows whose column 7 ("consider" flag, truncated to an
  integer) is 0 are dropped;
* MOT16/17/20 only: in each frame, result boxes are matched to *all* ground-truth boxes by the
  Hungarian algorithm on IoU (pairs with IoU < 0.5 cannot match), and a result box matched to
  a distractor-class box (person on vehicle, static person, distractor, reflection; for MOT20
  also non-MOT vehicle) is removed; then only pedestrian (class 1) ground truth is kept.

Similarity is box IoU; a match needs IoU >= 0.5 (CLEAR, Identity), HOTA averages over the
thresholds 0.05, 0.10, ..., 0.95.

References
----------
K. Bernardin, R. Stiefelhagen, "Evaluating multiple object tracking performance: the CLEAR MOT
metrics", EURASIP J. Image Video Process., 2008. E. Ristani et al., "Performance measures and a
data set for multi-target, multi-camera tracking", ECCV Workshops, 2016 (IDF1). J. Luiten et
al., "HOTA: a higher order metric for evaluating multi-object tracking", IJCV, 2021.

NumPy 2: the original TrackEval (GitHub ``JonathonLuiten/TrackEval``, issue #114) used aliases
removed in NumPy 1.24 (``np.float``, ``np.int``). The ``trackeval`` 1.3.0 release on PyPI, which
avtrack requires, no longer does; the modules used here run unchanged on NumPy 2.x.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from avtrack.io.mot import MOTData

#: Benchmarks whose preprocessing is reproduced.
BENCHMARKS = ("MOT15", "MOT16", "MOT17", "MOT20")

#: MOTChallenge ground-truth classes (column 8 of MOT16/17/20 ``gt.txt``).
_PEDESTRIAN = 1
_VALID_CLASSES = tuple(range(1, 14))
#: person_on_vehicle, static_person, distractor, reflection (TrackEval ``distractor_classes``).
_DISTRACTORS = (2, 7, 8, 12)
_NON_MOT_VEHICLE = 6  # a distractor in MOT20 only

_EPS = np.finfo(float).eps
_MATCH_IOU = 0.5

_PERCENT_FIELDS = ("MOTA", "MOTP", "IDF1", "HOTA", "IDP", "IDR", "DetA", "AssA")


@dataclass(frozen=True)
class MOTScores:
    """Scores of one sequence, as the MOTChallenge leaderboard reports them.

    Attributes
    ----------
    MOTA, MOTP, IDF1, HOTA : float
        Percentages (0-100; MOTA can be negative). MOTP is the mean IoU of matched pairs.
    FP, FN, IDSW, Frag : int
        False positives, false negatives (misses), identity switches, fragmentations.
    MT, PT, ML : int
        Ground-truth tracks mostly tracked (> 80 % of their frames), partly tracked, mostly
        lost (< 20 %).
    IDP, IDR : float
        Identity precision and recall, percent.
    DetA, AssA : float
        HOTA's detection and association accuracy, percent, averaged over IoU thresholds.
    n_gt_ids : int
        Ground-truth identities evaluated (after preprocessing).
    n_frames : int
        Frames in the sequence.
    n_gt_dets : int
        Ground-truth boxes evaluated (after preprocessing): MOTA's denominator.
    """

    MOTA: float
    MOTP: float
    IDF1: float
    HOTA: float
    FP: int
    FN: int
    IDSW: int
    Frag: int
    MT: int
    PT: int
    ML: int
    IDP: float
    IDR: float
    DetA: float
    AssA: float
    n_gt_ids: int
    n_frames: int
    n_gt_dets: int = 0

    def as_dict(self) -> dict[str, float | int]:
        """The scores as a plain ``{name: value}`` dict (JSON-serialisable)."""
        return asdict(self)


#: Columns of :func:`format_table` by default.
TABLE_COLUMNS = ("MOTA", "MOTP", "IDF1", "HOTA", "FP", "FN", "IDSW", "Frag", "MT", "ML")


def format_table(
    scores: MOTScores | Mapping[str, MOTScores],
    *,
    columns: tuple[str, ...] = TABLE_COLUMNS,
    markdown: bool = False,
) -> str:
    """Render scores as an aligned text table (or a Markdown table), one row per result.

    Parameters
    ----------
    scores : MOTScores or mapping of name to MOTScores
        One result, or several keyed by the name shown in the first column.
    columns : tuple of str
        :class:`MOTScores` fields to show; percentages get one decimal.
    markdown : bool
        Emit a GitHub Markdown table instead of space-aligned text.
    """
    rows = {"result": scores} if isinstance(scores, MOTScores) else dict(scores)
    fields = set(MOTScores.__dataclass_fields__)
    unknown = [c for c in columns if c not in fields]
    if unknown:
        raise ValueError(f"format_table: unknown columns {unknown}; expected names from {fields}")
    header = ["", *columns]
    body = [
        [name, *(_fmt(getattr(s, c), c in _PERCENT_FIELDS) for c in columns)]
        for name, s in rows.items()
    ]
    if markdown:
        lines = [
            "| " + " | ".join(header) + " |",
            "|" + "|".join(["---"] + ["---:"] * len(columns)) + "|",
        ]
        lines += ["| " + " | ".join(r) + " |" for r in body]
        return "\n".join(lines)
    widths = [max(len(r[i]) for r in [header, *body]) for i in range(len(header))]
    lines = [
        "  ".join(
            cell.ljust(w) if i == 0 else cell.rjust(w)
            for i, (cell, w) in enumerate(zip(r, widths, strict=True))
        ).rstrip()
        for r in [header, *body]
    ]
    return "\n".join(lines)


def _fmt(value: float | int, percent: bool) -> str:
    return f"{value:.1f}" if percent else str(value)


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of every pair of ``(left, top, width, height)`` boxes.

    Written operation for operation as TrackEval's ``_calculate_box_ious`` so that the two agree
    bit for bit (a box area is taken from the corner coordinates, not from ``w * h``).

    Parameters
    ----------
    a : ndarray (n, 4)
    b : ndarray (m, 4)

    Returns
    -------
    ndarray (n, m)
    """
    a = np.array(a, dtype=float, copy=True).reshape(-1, 4)
    b = np.array(b, dtype=float, copy=True).reshape(-1, 4)
    a[:, 2:] += a[:, :2]  # (x0, y0, w, h) -> (x0, y0, x1, y1)
    b[:, 2:] += b[:, :2]
    lo = np.minimum(a[:, None, :], b[None, :, :])
    hi = np.maximum(a[:, None, :], b[None, :, :])
    inter = np.maximum(lo[..., 2] - hi[..., 0], 0) * np.maximum(lo[..., 3] - hi[..., 1], 0)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a[:, None] + area_b[None, :] - inter  # |A ∪ B| = |A| + |B| - |A ∩ B|
    inter[area_a <= _EPS, :] = 0
    inter[:, area_b <= _EPS] = 0
    inter[union <= _EPS] = 0
    union[union <= _EPS] = 1
    return inter / union


def evaluate_mot(
    gt: MOTData,
    res: MOTData,
    *,
    benchmark: str = "MOT15",
    n_frames: int | None = None,
    threshold: float = _MATCH_IOU,
    similarity: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> MOTScores:
    """Score a tracker result against ground truth on one sequence, as MOTChallenge does.

    Parameters
    ----------
    gt : MOTData
        Ground truth (``read_mot(path, kind="gt")``). Column 7 is the "consider" flag; for
        MOT16/17/20 column 8 (``gt.extra[:, 0]``) is the object class (1..13).
    res : MOTData
        Tracker result (``read_mot(path, kind="result")``); ids must be >= 0 and unique within
        each frame.
    benchmark : {"MOT15", "MOT16", "MOT17", "MOT20"}
        Selects the preprocessing (see the module docstring).
    n_frames : int, optional
        Sequence length; defaults to the last frame in ``gt`` or ``res``. Only affects
        :attr:`MOTScores.n_frames`; frames beyond it must not occur.
    threshold : float
        Least similarity of a CLEAR-MOT / identity match (MOTChallenge: IoU 0.5; the thesis's
        audio-visual evaluation, §4.7.5, uses 0.1). HOTA always averages over 0.05..0.95.
    similarity : callable, optional
        ``similarity(gt_boxes (G, 4), res_boxes (R, 4)) -> (G, R)`` in [0, 1] for the boxes of
        one frame (ltwh); default IoU. E.g. a relaxed overlap for people outside the camera's
        view. The MOT16/17/20 distractor preprocessing always uses IoU.

    Returns
    -------
    MOTScores

    Raises
    ------
    TypeError
        ``gt`` or ``res`` is not a :class:`~avtrack.io.mot.MOTData`.
    ValueError
        Unknown benchmark; ``n_frames`` shorter than the data; a negative or repeated id in a
        frame; a NaN ground-truth flag; (MOT16/17/20) missing or invalid gt classes; a result
        with class (column 8) > 1, which TrackEval also rejects.
    """
    n_frames = _check_arguments(gt, res, benchmark, n_frames, threshold)
    data = _trackeval_data(gt, res, benchmark, n_frames, similarity)
    clear, ident, hota = _run_trackeval(data, float(threshold))
    return _scores(clear, ident, hota, data)


def _check_arguments(
    gt: MOTData, res: MOTData, benchmark: str, n_frames: int | None, threshold: float
) -> int:
    """Check :func:`evaluate_mot`'s arguments; the number of frames to score."""
    for name, d in (("gt", gt), ("res", res)):
        if not isinstance(d, MOTData):
            raise TypeError(f"evaluate_mot: {name} must be MOTData, got {type(d).__name__}")
    if benchmark not in BENCHMARKS:
        raise ValueError(f"evaluate_mot: benchmark must be one of {BENCHMARKS}, got {benchmark!r}")
    last = max(gt.n_frames, res.n_frames)
    if n_frames is None:
        n_frames = last
    elif isinstance(n_frames, bool) or not isinstance(n_frames, int | np.integer):
        raise TypeError(f"evaluate_mot: n_frames must be an int, got {type(n_frames).__name__}")
    elif n_frames < last:
        raise ValueError(
            f"evaluate_mot: n_frames must be >= the last frame in the data ({last}), "
            f"got {n_frames}"
        )
    n_frames = int(n_frames)
    if isinstance(threshold, bool) or not (
        isinstance(threshold, int | float) and 0 < threshold <= 1
    ):
        raise ValueError(f"evaluate_mot: threshold must be in (0, 1], got {threshold!r}")
    _check_ids(gt, "gt")
    _check_ids(res, "res")
    if len(gt) and not np.all(np.isfinite(gt.scores)):
        raise ValueError("evaluate_mot: gt column 7 (consider flag) must be finite, found NaN/inf")
    _check_result_classes(res)
    return n_frames


def _trackeval_data(
    gt: MOTData,
    res: MOTData,
    benchmark: str,
    n_frames: int,
    similarity: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
) -> dict[str, Any]:
    """TrackEval's per-sequence data: the benchmark's preprocessing applied frame by frame,
    ids relabelled ``0..n-1``, and the similarities of the kept gt and result boxes."""
    # the class of each gt row, where the benchmark has the distractor preprocessing
    gt_classes = _gt_classes(gt) if benchmark != "MOT15" else None
    distractors = _DISTRACTORS + ((_NON_MOT_VEHICLE,) if benchmark == "MOT20" else ())

    gt_keep = np.trunc(gt.scores) != 0  # TrackEval reads the flag with astype(int)
    if gt_classes is not None:
        gt_keep &= gt_classes == _PEDESTRIAN
    gt_ids_t: list[np.ndarray] = []
    res_ids_t: list[np.ndarray] = []
    sims_t: list[np.ndarray] = []
    for gs, rs in zip(gt.frame_slices(n_frames), res.frame_slices(n_frames), strict=True):
        sim = box_iou(gt.boxes[gs], res.boxes[rs])
        res_keep = np.ones(rs.stop - rs.start, dtype=bool)
        if gt_classes is not None and sim.size:
            res_keep[_distractor_matches(sim, gt_classes[gs], distractors)] = False
        if similarity is not None:
            sim = _custom_similarity(similarity, gt.boxes[gs], res.boxes[rs])
        g = gt_keep[gs]
        gt_ids_t.append(gt.ids[gs][g])
        res_ids_t.append(res.ids[rs][res_keep])
        sims_t.append(sim[g][:, res_keep])

    gt_ids_t, n_gt_ids = _relabel(gt_ids_t)
    res_ids_t, n_res_ids = _relabel(res_ids_t)
    data: dict[str, Any] = {
        "gt_ids": gt_ids_t,
        "tracker_ids": res_ids_t,
        "similarity_scores": sims_t,
        "num_gt_dets": int(sum(len(x) for x in gt_ids_t)),
        "num_tracker_dets": int(sum(len(x) for x in res_ids_t)),
        "num_gt_ids": n_gt_ids,
        "num_tracker_ids": n_res_ids,
        "num_timesteps": n_frames,
        "seq": "sequence",
    }
    return data


def _scores(clear: dict, ident: dict, hota: dict, data: dict[str, Any]) -> MOTScores:
    """The scores of TrackEval's CLEAR-MOT, identity and HOTA results, in percent."""
    n_gt_ids = data["num_gt_ids"]
    n_frames = data["num_timesteps"]
    return MOTScores(
        MOTA=100 * float(clear["MOTA"]),
        MOTP=100 * float(clear["MOTP"]),
        IDF1=100 * float(ident["IDF1"]),
        HOTA=100 * float(np.mean(hota["HOTA"])),  # averaged over the 19 IoU thresholds
        FP=int(clear["CLR_FP"]),
        FN=int(clear["CLR_FN"]),
        IDSW=int(clear["IDSW"]),
        Frag=int(clear["Frag"]),
        MT=int(clear["MT"]),
        PT=int(clear["PT"]),
        ML=int(clear["ML"]),
        IDP=100 * float(ident["IDP"]),
        IDR=100 * float(ident["IDR"]),
        DetA=100 * float(np.mean(hota["DetA"])),
        AssA=100 * float(np.mean(hota["AssA"])),
        n_gt_ids=n_gt_ids,
        n_frames=n_frames,
        n_gt_dets=data["num_gt_dets"],
    )




def _custom_similarity(fn, gb: np.ndarray, rb: np.ndarray) -> np.ndarray:
    sim = np.asarray(fn(gb, rb), dtype=float)
    if sim.shape != (len(gb), len(rb)):
        raise ValueError(
            f"evaluate_mot: similarity must return shape ({len(gb)}, {len(rb)}), got {sim.shape}"
        )
    if sim.size and not (np.all(np.isfinite(sim)) and sim.min() >= 0 and sim.max() <= 1):
        raise ValueError("evaluate_mot: similarity values must be finite and in [0, 1]")
    return sim


def _check_ids(d: MOTData, name: str) -> None:
    if not len(d):
        return
    if np.any(d.ids < 0):
        row = int(np.argmax(d.ids < 0))
        raise ValueError(
            f"evaluate_mot: {name} ids must be >= 0, got {int(d.ids[row])} at frame "
            f"{int(d.frames[row])} (rows with id -1 are unassigned detections: drop them)"
        )
    # rows are sorted by frame, so a repeated (frame, id) pair shows up in a lexsort
    order = np.lexsort((d.ids, d.frames))
    f, i = d.frames[order], d.ids[order]
    dup = (f[1:] == f[:-1]) & (i[1:] == i[:-1])
    if np.any(dup):
        k = int(np.argmax(dup))
        raise ValueError(
            f"evaluate_mot: {name} has id {int(i[k])} more than once in frame {int(f[k])}; "
            f"ids must be unique within a frame"
        )


def _check_result_classes(res: MOTData) -> None:
    # TrackEval reads column 8 of a result as its class and refuses anything but pedestrian
    if not len(res) or res.extra.shape[1] == 0:
        return
    cls = res.extra[:, 0]
    bad = np.isfinite(cls) & (np.trunc(cls) > _PEDESTRIAN)
    if np.any(bad):
        row = int(np.argmax(bad))
        raise ValueError(
            f"evaluate_mot: res column 8 (class) must be 1 (pedestrian) or -1, got "
            f"{cls[row]:g} at frame {int(res.frames[row])}"
        )


def _gt_classes(gt: MOTData) -> np.ndarray:
    if not len(gt):
        return np.zeros(0, dtype=np.int64)
    if gt.extra.shape[1] == 0 or not np.all(np.isfinite(gt.extra[:, 0])):
        raise ValueError(
            "evaluate_mot: MOT16/17/20 ground truth needs a class in column 8 for every row; "
            "use benchmark='MOT15' for files without classes"
        )
    classes = np.trunc(gt.extra[:, 0]).astype(np.int64)
    bad = ~np.isin(classes, _VALID_CLASSES)
    if np.any(bad):
        row = int(np.argmax(bad))
        raise ValueError(
            f"evaluate_mot: gt column 8 (class) must be in 1..13, got {classes[row]} at frame "
            f"{int(gt.frames[row])}"
        )
    return classes


def _distractor_matches(
    sim: np.ndarray, gt_classes: np.ndarray, distractors: tuple[int, ...]
) -> np.ndarray:
    """Indices of result boxes whose Hungarian match (IoU >= 0.5) is a distractor gt box."""
    score = sim.copy()
    score[score < _MATCH_IOU - _EPS] = 0
    rows, cols = linear_sum_assignment(-score)
    matched = score[rows, cols] > _EPS
    rows, cols = rows[matched], cols[matched]
    return cols[np.isin(gt_classes[rows], distractors)]


def _relabel(ids_t: list[np.ndarray]) -> tuple[list[np.ndarray], int]:
    """Map ids to 0..K-1 in increasing order of the original ids (as TrackEval does)."""
    if not ids_t:
        return [], 0
    unique, inverse = np.unique(np.concatenate(ids_t), return_inverse=True)
    splits = np.cumsum([len(x) for x in ids_t])[:-1]
    return [x.astype(int) for x in np.split(inverse, splits)], int(unique.size)


def _run_trackeval(data: dict[str, Any], threshold: float = _MATCH_IOU) -> tuple[dict, dict, dict]:
    try:
        from trackeval.metrics import CLEAR, HOTA, Identity
    except AttributeError as exc:  # a TrackEval built for NumPy < 1.24
        raise ImportError(
            f"trackeval failed to import with NumPy {np.__version__} ({exc}); "
            "install trackeval>=1.3.0"
        ) from exc
    config = {"THRESHOLD": threshold, "PRINT_CONFIG": False}
    with contextlib.redirect_stdout(io.StringIO()):  # TrackEval reports progress on stdout
        return (
            CLEAR(dict(config)).eval_sequence(data),
            Identity(dict(config)).eval_sequence(data),
            HOTA().eval_sequence(data),
        )
