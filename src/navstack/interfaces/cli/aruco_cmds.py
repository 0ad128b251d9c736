"""``navstack aruco``: ArUco markers in real camera images and videos.

``navstack aruco detect IMAGE|VIDEO --camera-info CALIB.yaml`` runs the detector of
:mod:`navstack.perception.aruco` on an image file (anything OpenCV reads: PNG, JPEG, ...)
or a video (read frame by frame) with the camera's calibration (the YAML written by ROS
``camera_calibration``, or CameraInfo fields), prints each marker's pose in the camera
frame and writes them as JSON with ``--json``.  Frames without markers are counted, not
errors.  ``navstack aruco generate ID`` writes a printable marker image.
"""

from __future__ import annotations

import math
import statistics
from pathlib import Path
from typing import Annotated, Any

import typer

from navstack.core.errors import ConfigError, NavstackError
from navstack.interfaces.cli.common import app, fail, write_json

aruco_app = typer.Typer(help="ArUco markers: detect in images and videos, generate markers.",
                        no_args_is_help=True)
app.add_typer(aruco_app, name="aruco")

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".webp"}


def _pose_record(frame: int, pose: Any) -> dict[str, Any]:
    r = pose.rotation
    # the marker's facing direction seen from the camera: yaw of its z axis about the
    # camera's y (down) axis, 0 when the marker faces the camera square-on
    facing = math.degrees(math.atan2(float(r[0, 2]), -float(r[2, 2])))
    return {"frame": frame, "id": pose.id,
            "x": round(float(pose.translation[0]), 4), "y": round(float(pose.translation[1]), 4),
            "z": round(float(pose.translation[2]), 4), "distance": round(pose.distance, 4),
            "facing_deg": round(facing, 2),
            "rotation": [[round(float(v), 6) for v in row] for row in r],
            "std_xyz": [round(math.sqrt(max(float(pose.covariance[i, i]), 0.0)), 5)
                        for i in range(3)],
            "reprojection_error_px": round(pose.reprojection_error, 4),
            "ambiguity": round(pose.ambiguity, 4), "confidence": round(pose.confidence, 4)}


@aruco_app.command("detect")
def detect(
    source: Annotated[Path, typer.Argument(help="Image or video file.")],
    camera_info: Annotated[Path, typer.Option(
        "--camera-info", help="Camera calibration YAML (camera_calibration format or "
                              "CameraInfo fields width, height, k, d).")],
    dictionary: Annotated[str, typer.Option(help="ArUco dictionary, e.g. DICT_4X4_50, "
                                                 "DICT_ARUCO_ORIGINAL.")] = "DICT_4X4_50",
    marker_size: Annotated[float, typer.Option(help="Side of the black square [m].")] = 0.1,
    max_frames: Annotated[int | None, typer.Option(min=1, help="Video: stop after N frames.")]
    = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write every pose here.")]
    = None,
) -> None:
    """Detect markers and their poses (camera frame: x right, y down, z forward)."""
    import cv2

    from navstack.perception.aruco import ArucoDetector, ArucoParams, load_camera_info

    try:
        params = ArucoParams.from_mapping({"dictionary": dictionary, "marker_size": marker_size})
    except ConfigError as exc:
        option = exc.key_path.replace("_", "-")
        raise fail(f"option --{option}: {exc.reason.removeprefix('Value error, ')}") from None
    try:
        detector = ArucoDetector(params)
        camera = load_camera_info(camera_info)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    if not source.is_file():
        raise fail(f"{source}: no such file")
    records: list[dict[str, Any]] = []
    frames = 0

    def run(frame: Any) -> None:
        nonlocal frames
        h, w = frame.shape[:2]
        if (w, h) != (camera.width, camera.height):
            raise fail(f"{source}: frame {frames} is {w} x {h} but {camera_info} calibrates "
                       f"a {camera.width} x {camera.height} camera; use the matching "
                       "calibration (or resize the images)")
        try:
            poses = detector.process(frame, camera)
        except NavstackError as exc:
            raise fail(f"{source}: frame {frames}: {exc}") from None
        records.extend(_pose_record(frames, p) for p in poses)
        frames += 1

    if source.suffix.lower() in IMAGE_SUFFIXES:
        image = cv2.imread(str(source), cv2.IMREAD_UNCHANGED)
        if image is None:
            raise fail(f"{source}: OpenCV cannot read this image")
        if image.dtype != "uint8":
            raise fail(f"{source}: {image.dtype} pixels; ArUco detection needs an 8-bit image "
                       "(mono8 or bgr8)")
        run(image)
        kind = "image"
    else:
        capture = cv2.VideoCapture(str(source))
        if not capture.isOpened():
            raise fail(f"{source}: OpenCV cannot open this video (or image: use one of "
                       f"{', '.join(sorted(IMAGE_SUFFIXES))})")
        try:
            while max_frames is None or frames < max_frames:
                ok, frame = capture.read()
                if not ok:
                    break
                run(frame)
        finally:
            capture.release()
        kind = "video"
        if frames == 0:
            raise fail(f"{source}: the video has no frames OpenCV can decode")
    stats = detector.stats
    for r in records[:50]:
        typer.echo(f"frame {r['frame']}: id {r['id']} at ({r['x']:.3f}, {r['y']:.3f}, "
                   f"{r['z']:.3f}) m, distance {r['distance']:.3f} m, facing "
                   f"{r['facing_deg']:.1f} deg, reprojection {r['reprojection_error_px']:.2f} px")
    if len(records) > 50:
        typer.echo(f"... {len(records) - 50} more (see --json)")
    by_id: dict[int, list[float]] = {}
    for r in records:
        by_id.setdefault(r["id"], []).append(r["distance"])
    summary = {str(k): {"detections": len(v), "median_distance": statistics.median(v)}
               for k, v in sorted(by_id.items())}
    typer.echo(f"{kind}: {frames} frame(s), {stats.frames_without_markers} without markers, "
               f"{len(records)} marker pose(s)"
               + (f"; ids {', '.join(summary)}" if summary else ""))
    write_json(json_out, {"source": str(source), "kind": kind, "frames": frames,
                          "frames_without_markers": stats.frames_without_markers,
                          "camera_info": str(camera_info), "dictionary": params.dictionary,
                          "marker_size": marker_size, "markers": summary, "poses": records})


@aruco_app.command("generate")
def generate(
    marker_id: Annotated[int, typer.Argument(help="Marker id in the dictionary.")],
    out: Annotated[Path, typer.Option(help="Image file to write (PNG).")],
    dictionary: Annotated[str, typer.Option(help="ArUco dictionary.")] = "DICT_4X4_50",
    pixels: Annotated[int, typer.Option(min=16, help="Side of the marker [px].")] = 400,
    margin: Annotated[int, typer.Option(min=0, help="White border [px].")] = 50,
) -> None:
    """Write a printable marker image (black square of ``pixels`` plus a white margin)."""
    import cv2

    from navstack.core.aruco_dictionaries import check_marker_id, get_dictionary

    try:
        check_marker_id(dictionary, marker_id, key_path="MARKER_ID")
        d = get_dictionary(dictionary)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    img = cv2.aruco.generateImageMarker(d, marker_id, pixels)
    img = cv2.copyMakeBorder(img, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), img):
        raise fail(f"{out}: OpenCV cannot write this file type; use .png")
    typer.echo(f"wrote marker {marker_id} of {dictionary} ({pixels} px + {margin} px margin) "
               f"to {out}")
