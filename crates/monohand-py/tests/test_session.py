"""The session on a real photo seen by a moving camera, against `monohand run` on the same
video; video reading; the GIL released; bad input."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

import monohand
from conftest import read_jsonl, records_without_timings, run_cli


def test_session_equals_the_cli_on_the_same_video(tmp_path, moving_video):
    out = tmp_path / "cli.jsonl"
    run_cli("run", str(moving_video), "-o", str(out), "--hands", "2")
    cli = read_jsonl(out)

    with monohand.read_video(str(moving_video)) as video, monohand.Session(None, hands=2) as s:
        assert video.size == (640, 480) and video.fps == 30.0
        py = [(f.index, f.time_s, s.process(f.image, f.time_s)) for f in video]

    assert len(py) == len(cli) == 40, "frames in = frames out"
    fitted = 0
    for (index, time_s, hands), rec in zip(py, cli):
        assert index == rec["frame"] and time_s == pytest.approx(rec["time_s"])
        assert len(hands) == len(rec["hands"])
        for h, r in zip(hands, rec["hands"]):
            d = h.to_dict()
            # Bit for bit: the same code path, the same numbers.
            for key in ("id", "side", "keypoints_2d", "joints_3d_mm", "pose", "reprojection_error_px", "score", "side_score", "distance"):
                assert d.get(key) == r.get(key), (index, key)
            assert np.array_equal(h.keypoints_2d, np.array(r["keypoints_2d"]))
            assert h.distance == r.get("distance"), index
            if h.joints_3d_mm is not None:
                fitted += 1
                # One camera, tracked: the palm's distance, the keypoints' and the filter's.
                dist = h.distance
                assert 100.0 < dist["fused_mm"] < 2000.0 and 0.0 < dist["fused_sigma_mm"] < dist["fused_mm"], dist
                assert dist["keypoints_sigma_mm"] > 0.0 and dist["cues_mm"] > 0.0, dist
                assert np.array_equal(h.joints_3d_mm, np.array(r["joints_3d_mm"]))
                assert h.joints_3d_mm.shape == (21, 3) and h.joints_3d_mm[0, 2] > 100.0
    assert fitted >= 38, f"the photo's hand is fitted in nearly every frame ({fitted}/40)"
    assert len({h.id for _, _, hs in py for h in hs}) == 1, "one hand, one id"


def test_without_the_mirror_pass_the_session_equals_the_cli_without_it(tmp_path, moving_video):
    out = tmp_path / "cli.jsonl"
    run_cli("run", str(moving_video), "-o", str(out), "--hands", "2", "--no-mirror-pass")
    cli = read_jsonl(out)
    models = monohand.Models(hands=2, mirror_pass=False)
    assert models.mirror_pass is False and "mirror_pass=False" in repr(models)
    with pytest.raises(ValueError, match="mirror_pass=True"):
        monohand.Session(None, hands=2, models=models)
    with monohand.read_video(str(moving_video)) as video, monohand.Session(
        None, hands=2, models=models, mirror_pass=False
    ) as s, monohand.Session(None, hands=2) as both:
        differs = 0
        for f, rec in zip(video, cli):
            hands = s.process(f.image, f.time_s)
            assert [h.to_dict()["keypoints_2d"] for h in hands] == [r["keypoints_2d"] for r in rec["hands"]]
            assert [h.to_dict().get("joints_3d_mm") for h in hands] == [r.get("joints_3d_mm") for r in rec["hands"]]
            default = both.process(f.image, f.time_s)
            differs += any(
                not np.array_equal(a.keypoints_2d, b.keypoints_2d) for a, b in zip(hands, default)
            )
    # The default (both passes) reads the crops otherwise: its keypoints differ.
    assert differs >= 30, f"the mirror pass changed the keypoints of {differs} of 40 frames"


def test_track_runs_the_cli_engine_and_gives_its_records(tmp_path, moving_video, models):
    """`Session.track` is `monohand run`'s engine: the same records, timings aside, with the
    camera each frame was fitted with; it streams (frames come as they are done) and ends
    with a summary."""
    out = tmp_path / "cli.jsonl"
    run_cli("run", str(moving_video), "-o", str(out), "--hands", "2")
    cli = read_jsonl(out)
    with monohand.Session(None, hands=2, models=models) as s:
        stream = s.track(str(moving_video))
        assert stream.summary is None, "no summary before the end"
        frames = list(stream)
        summary = stream.summary
        notes = stream.notes()
    assert len(frames) == len(cli) == 40
    for f, rec in zip(frames, cli):
        d = f.to_dict()
        d.pop("timings_ms"), rec.pop("timings_ms")
        assert d == rec, f.index
        assert f.index == rec["frame"] and f.time_s == rec["time_s"]
        assert [h.to_dict() for h in f.hands] == rec["hands"]
    assert frames[0].cameras == [
        {"fx": pytest.approx(320 / np.tan(np.radians(30))), "fy": pytest.approx(320 / np.tan(np.radians(30))),
         "cx": 319.5, "cy": 239.5, "width": 640, "height": 480, "source": "generic"}
    ]
    assert summary["frames"] == 40 and summary["hands_3d"] >= 38 and summary["fps"] > 0
    assert any("generic camera for 640x480" in n for n in notes), notes
    assert not any("--" in n for n in notes), f"a library note names a CLI flag: {notes}"
    # A given camera is said to come from the caller ("file"), and max_frames stops early.
    cam = monohand.Camera(600.0, 600.0, 320.0, 240.0, 640, 480)
    with monohand.Session(cam, hands=2, models=models) as s:
        few = list(s.track(str(moving_video), max_frames=5))
    assert [f.index for f in few] == [0, 1, 2, 3, 4]
    assert few[0].cameras[0]["source"] == "file" and few[0].cameras[0]["fx"] == 600.0


def test_offline_track_equals_the_cli_offline(tmp_path, moving_video, models):
    """`track(offline=True)` is `monohand run --offline`: the same records; every frame comes
    out, in order, with the causal run's hands and keypoints and refitted 3D."""
    out = tmp_path / "cli.jsonl"
    run_cli("run", str(moving_video), "-o", str(out), "--hands", "2", "--offline")
    cli = read_jsonl(out)
    with monohand.Session(None, hands=2, models=models) as s:
        offline = list(s.track(str(moving_video), offline=True))
        causal = list(s.track(str(moving_video)))
    assert len(offline) == len(cli) == len(causal) == 40
    moved = 0
    for f, rec, c in zip(offline, cli, causal):
        d = f.to_dict()
        d.pop("timings_ms"), rec.pop("timings_ms")
        assert d == rec, f.index
        assert [h.to_dict()["keypoints_2d"] for h in f.hands] == [
            h.to_dict()["keypoints_2d"] for h in c.hands
        ]
        for a, b in zip(f.hands, c.hands):
            if a.joints_3d_mm is not None and b.joints_3d_mm is not None:
                moved += not np.allclose(a.joints_3d_mm, b.joints_3d_mm, atol=0.1)
    assert moved >= 20, f"{moved} hands refitted"


def test_track_takes_the_callers_own_frames_on_the_engines_path(tmp_path, moving_video, models):
    """`track` over frames the caller's code makes (read_video's frames, (image, time_s)
    pairs, bare arrays) is `run`'s engine too: the same records as `track(path)`, timings
    aside; an exception of the caller's iterable, or a frame that is not an image, is raised
    as it was after the frames before it."""
    with monohand.Session(None, hands=2, models=models) as s:
        by_path = records_without_timings(s.track(str(moving_video)))
        with monohand.read_video(str(moving_video)) as video:
            by_frames = records_without_timings(s.track(video))
        with monohand.read_video(str(moving_video)) as video:
            decoded = [(f.image, f.time_s) for f in video]
        images = [im for im, _ in decoded]
        by_pairs = records_without_timings(s.track(iter(decoded)))
        by_arrays = records_without_timings(s.track(iter(images)))
        at_30 = records_without_timings(s.track((im, i / 30.0) for i, im in enumerate(images)))
        few = records_without_timings(s.track(images, max_frames=3))
    assert len(by_path) == 40 and sum(len(d["hands"]) for d in by_path) >= 38
    assert by_frames == by_path
    assert by_pairs == by_path
    assert [d["time_s"] for d in by_path[:3]] == [0.0, 0.033, 0.067], "the file's clock (ms)"
    assert by_arrays == at_30, "without a time: 30 frames a second"
    assert [d["time_s"] for d in by_arrays[:3]] == [0.0, 1 / 30, 2 / 30]
    assert few == at_30[:3]

    def broken():
        yield from images[:5]
        raise KeyError("the camera went away")

    got = []
    with monohand.Session(None, hands=2, models=models) as s:
        with pytest.raises(KeyError, match="the camera went away"):
            for f in s.track(broken()):
                got.append(f.index)
        assert got == [0, 1, 2, 3, 4]
        got = []
        with pytest.raises(ValueError, match=r"uint8 array of shape \(H, W, 3\)"):
            for f in s.track(images[:2] + [images[2].astype(np.float32)] + images[3:]):
                got.append(f.index)
        assert got == [0, 1]
        with pytest.raises(ValueError, match="time_s must be finite"):
            list(s.track([(images[0], float("nan"))]))
        with pytest.raises(ValueError, match="one per camera"):
            list(s.track([[images[0], images[1]]]))
        with pytest.raises(ValueError, match="frames given by the caller"):
            s.track(images, sync="auto")
        with pytest.raises(ValueError, match="iterable of frames"):
            s.track(42)


def test_track_raises_on_a_missing_input_and_after_a_broken_video(tmp_path, moving_video, models):
    with monohand.Session(None, hands=2, models=models) as s:
        with pytest.raises(monohand.MonohandError, match="no such file"):
            s.track(str(tmp_path / "missing.mp4"))
        cut = tmp_path / "cut.mkv"
        data = moving_video.read_bytes()
        cut.write_bytes(data[: len(data) // 2])
        got = []
        with pytest.raises(monohand.MonohandError):
            for f in s.track(str(cut)):
                got.append(f.index)
        assert got == list(range(len(got))), "the good frames come first, in order"


def test_frames_are_handed_over_without_a_copy(moving_video):
    with monohand.read_video(str(moving_video)) as video:
        frame = next(iter(video))
        img = frame.image
        assert img.shape == (480, 640, 3) and img.dtype == np.uint8
        assert img.flags["C_CONTIGUOUS"] and img.flags["OWNDATA"] is False  # wraps Rust's buffer
        assert img.mean() > 10.0


def test_the_gil_is_released_while_the_networks_run(moving_video, models):
    with monohand.read_video(str(moving_video)) as video:
        images = [f.image for f in video][:20]
    ticks = 0
    stop = threading.Event()

    def count():
        nonlocal ticks
        while not stop.is_set():
            ticks += 1
            time.sleep(0)

    with monohand.Session(None, models=models) as s:
        s.process(images[0])  # warm up
        t = threading.Thread(target=count)
        t.start()
        start = time.perf_counter()
        for img in images[1:]:
            s.process(img)
        busy = time.perf_counter() - start
        stop.set()
        t.join()
    # A Python thread blocked on the GIL would barely tick in the ~20 ms of each frame.
    assert ticks > 200 * busy, (ticks, busy)


def test_two_sessions_share_one_set_of_networks(moving_video, models):
    with monohand.read_video(str(moving_video)) as video:
        images = [f.image for f in video][:5]
    a = monohand.Session(None, models=models)
    b = monohand.Session(None, models=models)
    for img in images:
        ha, hb = a.process(img), b.process(img)
        assert [h.to_dict() for h in ha] == [h.to_dict() for h in hb]
    with pytest.raises(ValueError, match="models were loaded"):
        monohand.Session(None, hands=1, models=models)


def test_rectified_crops_equal_the_cli_with_them(tmp_path, moving_video):
    import json

    cam = monohand.Camera.generic(640, 480)
    cam_file = tmp_path / "cam.json"
    cam_file.write_text(json.dumps(dict(fx=cam.fx, fy=cam.fy, cx=cam.cx, cy=cam.cy, width=640, height=480)))
    out = tmp_path / "cli.jsonl"
    run_cli("run", str(moving_video), "--camera", str(cam_file), "-o", str(out), "--hands", "2", "--rectify-crops", "all")
    cli = read_jsonl(out)
    with pytest.raises(ValueError, match="rectify_crops.*off, lenses or all"):
        monohand.Session(cam, rectify_crops="sometimes")
    with monohand.read_video(str(moving_video)) as video, monohand.Session(cam, hands=2, rectify_crops="all") as s:
        fitted = 0
        for f, rec in zip(video, cli):
            hands = s.process(f.image, f.time_s)
            # Bit for bit: the rectified views are the same code path as the CLI's.
            assert [h.to_dict()["keypoints_2d"] for h in hands] == [r["keypoints_2d"] for r in rec["hands"]]
            assert [h.to_dict().get("joints_3d_mm") for h in hands] == [r.get("joints_3d_mm") for r in rec["hands"]]
            fitted += sum(h.joints_3d_mm is not None for h in hands)
    assert fitted >= 38, f"the hand is fitted in nearly every frame ({fitted}/40)"


def test_bad_input_raises_clear_errors(tmp_path, models):
    cam = monohand.Camera.generic(640, 480)
    with monohand.Session(cam, models=models) as s:
        with pytest.raises(ValueError, match="H, W, 3"):
            s.process(np.zeros((480, 640), dtype=np.uint8))
        with pytest.raises(ValueError, match="uint8"):
            s.process(np.zeros((480, 640, 3), dtype=np.float32))
        with pytest.raises(ValueError, match="camera"):
            s.process([np.zeros((480, 640, 3), dtype=np.uint8)] * 2)
        # An image of another shape than the calibration: said, not guessed. (One of the
        # same shape at another size gets the calibration scaled: docs/calibration.md.)
        with pytest.raises(monohand.MonohandError, match="640x480|size|aspect"):
            s.process(np.zeros((320, 320, 3), dtype=np.uint8))
        assert s.process(np.zeros((240, 320, 3), dtype=np.uint8)) == []
        assert s.cameras[0].width == 320 and s.cameras[0].fx == pytest.approx(cam.fx / 2)
        # An empty image has no hands.
        assert s.process(np.zeros((480, 640, 3), dtype=np.uint8)) == []
        # A strided view is copied, not misread.
        big = np.zeros((480, 1280, 3), dtype=np.uint8)
        assert s.process(big[:, ::2]) == []
    with pytest.raises(ValueError, match="closed"):
        s.process(np.zeros((480, 640, 3), dtype=np.uint8))
    with pytest.raises(ValueError):
        monohand.Session(None, hands=0)
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(np.random.default_rng(0).integers(0, 255, 4096, dtype=np.uint8).tobytes())
    with pytest.raises(monohand.MonohandError):
        list(monohand.read_video(str(junk)))
    with pytest.raises(monohand.MonohandError):
        monohand.read_video(str(tmp_path / "missing.mp4"))


def test_track_video_gives_one_row_per_frame_per_hand(moving_video, models):
    df = monohand.track_video(str(moving_video), max_frames=12)
    assert list(df["frame"]) == list(range(12))
    assert df["hand_id"].nunique() == 1
    assert all(len(j) == 21 for j in df["joints_3d_mm"] if j is not None)
    table = monohand.track_video(str(moving_video), max_frames=3, output="arrow")
    assert table.schema == monohand.row_schema() and table.num_rows == 3
    wrist_z = np.array([j[0][2] for j in df["joints_3d_mm"]])
    assert (wrist_z > 100.0).all() and (wrist_z < 2000.0).all()


def test_a_calibrated_stereo_rig_equals_the_cli(tmp_path):
    """STB's real stereo pair (frame 0 of B1Counting) with its real cameras: the session
    over both views gives the CLI's numbers, and a hand between 20 and 80 cm away."""
    import json

    from conftest import shared

    d = shared("stb_b1counting")
    k = json.loads((d / "camera_params.json").read_text())["BB2Stereo"]
    intr = dict(fx=k["fx"], fy=k["fy"], cx=k["tx"], cy=k["ty"], width=640, height=480)
    left = monohand.Camera(**intr)
    right = monohand.Camera(**intr, translation_mm=[-k["baseline"], 0.0, 0.0])
    assert np.array_equal(right.rotation, np.eye(3)) and right.translation_mm[0] == -k["baseline"]
    with pytest.raises(ValueError, match="rotation"):
        monohand.Camera(**intr, rotation=[[1, 0, 0], [0, 1, 0], [0, 0, 2]])

    images = []
    for side in ("left", "right"):
        with monohand.read_video(str(d / "images" / "B1Counting" / f"BB_{side}_0.png")) as v:
            images.append(next(iter(v)).image)
    with monohand.Session([left, right], tracking=False) as s:
        hands = s.process(images)
    assert len(hands) >= 1 and hands[0].joints_3d_mm is not None
    assert 200.0 < hands[0].joints_3d_mm[0, 2] < 800.0

    cams = []
    for name, cam in (("left", left), ("right", right)):
        p = tmp_path / f"{name}.json"
        p.write_text(json.dumps({**intr, "t": cam.translation_mm.tolist()}))
        cams.append(p)
    out = tmp_path / "stereo.jsonl"
    run_cli(
        "run", "--view", str(d / "images/B1Counting/BB_left_0.png"), "--camera", str(cams[0]),
        "--view", str(d / "images/B1Counting/BB_right_0.png"), "--camera", str(cams[1]),
        "--hands", "2", "-o", str(out),
    )
    rec = read_jsonl(out)[0]["hands"]
    assert [h.to_dict().get("joints_3d_mm") for h in hands] == [r.get("joints_3d_mm") for r in rec]


def test_int8_sessions_equal_the_cli_in_int8_and_say_so(tmp_path, moving_video):
    """`precision="int8"`: the same records as `run --precision int8`, each saying
    `"precision": "int8"`, keypoints near (not equal to) f32's; a bad name is refused; the
    default `"auto"` takes shared models' precision."""
    out = tmp_path / "cli.jsonl"
    run_cli("run", str(moving_video), "-o", str(out), "--hands", "2", "--precision", "int8")
    cli = read_jsonl(out)
    assert all(rec.get("precision") == "int8" for rec in cli)
    with pytest.raises(ValueError, match="precision"):
        monohand.Models(hands=2, precision="int4")
    models = monohand.Models(hands=2, precision="int8")
    assert models.precision == "int8" and 'precision="int8"' in repr(models)
    with pytest.raises(ValueError, match="precision"):
        monohand.Session(None, hands=2, models=models, precision="f32")
    with pytest.raises(ValueError, match="auto, f32 or int8"):
        monohand.Session(None, hands=2, precision="int4")
    # precision="auto" (the default) with models takes the models' int8.
    with monohand.Session(None, hands=2, models=models) as s:
        frames = [f.to_dict() for f in s.track(str(moving_video))]
    with monohand.Session(None, hands=2) as s:
        f32 = [f.to_dict() for f in s.track(str(moving_video))]
    assert len(frames) == len(cli) == len(f32) == 40
    near = 0
    for ours, theirs, full in zip(frames, cli, f32):
        for rec in (ours, theirs, full):
            rec.pop("timings_ms", None)
        assert ours == theirs, ours["frame"]
        assert "precision" not in full, "f32 records say nothing"
        for a, b in zip(ours["hands"], full["hands"]):
            d = np.linalg.norm(np.array(a["keypoints_2d"])[:, :2] - np.array(b["keypoints_2d"])[:, :2], axis=1)
            near += d.mean() < 2.0
    assert near >= 35, f"int8 keypoints within 2 px of f32's in {near} of 40 frames"


def test_a_hand_size_sizes_the_session_as_the_cli_and_is_saved_and_loaded(tmp_path, moving_video):
    # A ruler's hand (the hand flat, wrist crease to the end of the middle finger), saved and
    # read back: the file the CLI's --hand reads.
    ruler = monohand.HandSize.from_length(175.0)
    assert ruler.source == "ruler" and 0.9 < ruler.scale < 0.93 and ruler.frames == []
    path = tmp_path / "hand.json"
    ruler.save(path)
    hand = monohand.HandSize.load(path)
    assert (hand.scale, hand.hand_length_mm, hand.source) == (ruler.scale, ruler.hand_length_mm, "ruler")

    out = tmp_path / "cli.jsonl"
    run_cli("run", str(moving_video), "-o", str(out), "--hand", str(path))
    cli = read_jsonl(out)
    with monohand.read_video(str(moving_video)) as video, monohand.Session(None, hand=str(path)) as s:
        py = [s.process(f.image, f.time_s) for f in video]
    fitted = 0
    for hands, rec in zip(py, cli):
        for h, r in zip(hands, rec["hands"]):
            d = h.to_dict()
            assert d.get("joints_3d_mm") == r.get("joints_3d_mm")
            if r.get("joints_3d_mm") is not None:
                fitted += 1
                assert d["hand_size"] == r["hand_size"]
                assert r["hand_size"]["source"] == "file"
                assert r["hand_size"]["scale"] == pytest.approx(hand.scale, rel=1e-12)
    assert fitted >= 38, fitted
    # The same hand without the file: the ruler's, said as such; the default, as such.
    with monohand.Session(None, hand=ruler) as s, monohand.read_video(str(moving_video)) as video:
        first = next(h for f in video for h in s.process(f.image, f.time_s) if h.joints_3d_mm is not None)
    assert first.to_dict()["hand_size"]["source"] == "ruler"

    with pytest.raises(ValueError, match="not both"):
        monohand.Session(None, hand=hand, hand_scale=0.9)
    with pytest.raises(ValueError, match="by ruler is outside"):
        monohand.HandSize.from_length(20.0)
    with pytest.raises(monohand.MonohandError, match="missing.json"):
        monohand.HandSize.load(tmp_path / "missing.json")
