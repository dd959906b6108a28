// Types of monohand in the browser (web/monohand.js). The records are those `monohand run`
// writes as JSON Lines, documented in docs/output-format.md; optional fields are absent
// (never null) when unknown, and readers should ignore fields they do not know.

/** A point `[x, y, z]`, millimetres, in the camera's frame (OpenCV axes: x right, y down, z forward). */
export type Vec3 = [number, number, number];

/** 21 values, one per joint, in MediaPipe's (and OpenPose's) order: 0 wrist; 1-4 thumb; 5-8 index; 9-12 middle; 13-16 ring; 17-20 little. */
export type Joints<T> = [T, T, T, T, T, T, T, T, T, T, T, T, T, T, T, T, T, T, T, T, T];

/** Where a camera came from. */
export type CameraSource = 'file' | 'file-scaled' | 'exif' | 'exif+sensor-db' | 'video-metadata' | 'generic';

/** A camera's intrinsics: focal lengths and principal point, pixels, for an image size. */
export interface Intrinsics {
  fx: number;
  fy: number;
  cx: number;
  cy: number;
  width: number;
  height: number;
}

/** The camera a frame's hands were fitted with (docs/output-format.md, "Camera object"). */
export interface CameraRecord extends Intrinsics {
  /** The lens model, when the camera is not an ideal pinhole. */
  model?: 'pinhole' | 'fisheye';
  /** Its distortion coefficients, with `model` (OpenCV's order; a fisheye's k1..k4). */
  dist?: number[];
  source: CameraSource;
  /** Why this source and not a better one, when there is something to say. */
  reason?: string;
}

/** The fitted model's parameters (docs/output-format.md, "Pose object"). */
export interface PoseRecord {
  /** The wrist of the posed skeleton, mm, in the camera's frame. */
  translation_mm: Vec3;
  /** Unit quaternion `[x, y, z, w]`: from the hand model's frame to the camera's. */
  quaternion_xyzw: [number, number, number, number];
  /** The 20 joint angles, radians: per finger (thumb, index, middle, ring, little) base flexion, base abduction, middle flexion, distal flexion. */
  angles_rad: number[];
}

/** The hand's box turned with the hand (its height axis from the wrist to the fingers). */
export interface OrientedBox {
  center: [number, number];
  size: [number, number];
  /** Clockwise in the image from "fingers up", degrees. */
  angle_deg: number;
}

/** One hand of a frame (docs/output-format.md, "Hand object"). */
export interface HandRecord {
  side: 'left' | 'right';
  /** `[u, v, confidence]`: pixels (x right, y down, pixel centres at integers) and [0, 1]; confidence 0 marks a missing joint. */
  keypoints_2d: Joints<[number, number, number]>;
  /** The fitted joints, mm, in the camera's frame: where the hand is. Absent when the hand could not be fitted. */
  joints_3d_mm?: Joints<Vec3>;
  pose?: PoseRecord;
  /** Mean pixel distance between the keypoints used and the reprojected joints. */
  reprojection_error_px?: number;
  /** The solver met a stopping tolerance before its iteration cap. */
  converged?: boolean;
  iterations?: number;
  /** Bounds of the keypoints `[x_min, y_min, x_max, y_max]`, pixels. */
  box?: [number, number, number, number];
  oriented_box?: OrientedBox;
  /** The palm detector's score, [0, 1]. */
  score?: number;
  /** The probability of `side` from the landmark network on this frame (the side itself is a vote over the hand's frames). */
  side_score?: number;
  /** The hand's identity, stable while it is tracked. */
  id?: number;
  /** The network's own metric 3D of the hand, mm, relative to the hand, in the image's axes. */
  world_mm?: Joints<Vec3>;
  /** The network's depth of each joint relative to the wrist, image pixels, negative towards the camera. */
  depth_px?: Joints<number>;
  /** The hand's 26 OpenXR joints (with the tracker's `xrJoints` option; fitted hands only), in `XrHandJointEXT` order: `palm`, `wrist`, `thumb_metacarpal`, ..., `little_tip`. {@link webxrJoints} gives them as WebXR's. */
  xr_joints?: XrJointRecord[];
  /** The hand size the fit used (with the 3D): the model's wrist-to-middle-fingertip length, the factor on the default adult hand, and where it came from ('default', 'file' for the `hand` option, 'ruler' for `handLengthMm`). */
  hand_size?: { length_mm: number; scale: number; source: 'default' | 'scale' | 'measured' | 'file' | 'ruler' };
  /** With one camera and a tracked hand: the palm's distance from the camera, mm, as the keypoints alone, the network's cues and the filter over the track gave it (docs/output-format.md, "distance object"). */
  distance?: { keypoints_mm?: number; keypoints_sigma_mm?: number; cues_mm?: number; fused_mm: number; fused_sigma_mm: number };
}

/** One OpenXR joint of a hand (docs/output-format.md, "XR joint object"), in the camera's frame. */
export interface XrJointRecord {
  name: string;
  position_mm: Vec3;
  /** The rotation from the joint's axes (-Z along its bone towards the finger tip, +Y out of the back of the hand) into the camera's frame, `[x, y, z, w]`. */
  orientation_xyzw: [number, number, number, number];
  /** The joint's distance to the skin, mm. */
  radius_mm: number;
}

/** A joint's pose shaped as WebXR's `XRJointPose` (metres, in the camera as WebXR's `viewer` space: x right, y up, z towards the viewer). */
export interface WebXRJointPose {
  transform: {
    position: { x: number; y: number; z: number; w: number };
    orientation: { x: number; y: number; z: number; w: number };
    /** Column-major 4x4, as `XRRigidTransform.matrix`. */
    matrix: Float32Array;
  };
  radius: number;
}

/** WebXR's 25 hand joint names (`XRHandJoint`), in the spec's order. */
export declare const WEBXR_JOINT_NAMES: readonly string[];

/** The WebXR name of an OpenXR joint's record name, or `null` for the palm. */
export declare function webxrJointName(openxrName: string): string | null;

/** A hand's 25 WebXR joint poses by name, in WebXR's order, or `null` when the hand has no `xr_joints`. */
export declare function webxrJoints(hand: HandRecord): Map<string, WebXRJointPose> | null;

/** One frame's record (docs/output-format.md, "Frame object"). */
export interface FrameRecord {
  /** The frame's index from 0, in the order the tracker was given them. */
  frame: number;
  /** The time the page gave `track`, seconds. */
  time_s?: number;
  /** `[width, height]`, pixels. */
  image_size?: [number, number];
  /** The camera the hands were fitted with. */
  cameras?: CameraRecord[];
  hands: HandRecord[];
  /** Why this frame has no result. */
  error?: string;
  /** Processing time per stage, ms (`vision`, `fit`, ...). */
  timings_ms?: Record<string, number>;
}

/** A hand file (`monohand run --save-hand`, docs/absolute-depth.md). */
export interface HandFile {
  format: 'monohand-hand/1';
  source: 'views' | 'ruler';
  /** The size, a factor on the default adult hand. */
  scale: number;
  scale_sigma?: number;
  /** The model's wrist-to-middle-fingertip length at that size, mm. */
  hand_length_mm: number;
  side?: 'left' | 'right';
  views?: number;
  frames?: number[];
  ruler_mm?: number;
  bone_lengths_mm?: (number | null)[];
  bone_sigma_mm?: (number | null)[];
}

/** Options of {@link createTracker}; every one may be left out. */
export interface TrackerOptions {
  /** The folder the weights are fetched from, a URL relative to the page (default: the `weights/` folder beside monohand.js). */
  weights?: string;
  /** The palm detector's weights: a file name in `weights`, or the bytes of a file the user picked (default `palm_detection_full.tflite`). */
  palm?: string | Uint8Array;
  /** The hand landmark network's weights, the same way (default `hand_landmark_full.tflite`). */
  landmark?: string | Uint8Array;
  /** The most hands per frame (default 2). */
  hands?: number;
  /** Look for new hands every this many frames while tracking (default 10). */
  detectEvery?: number;
  /** Whether the landmark network also reads each crop's mirror image (default true; false: one network pass a hand instead of two, as MediaPipe does, about twice as fast, at a higher 3D error). */
  mirrorPass?: boolean;
  /** The networks' arithmetic: "f32" (the default, MediaPipe's own) or "int8" (the 1x1 and first convolutions of both networks in int8, with monohand's shipped calibration; the records then say `"precision": "int8"`). int8 is fast only where the tracker runs threaded (`threads > 1`: the module with relaxed SIMD, about 0.6x f32's time a frame); on one thread its kernel is the portable one, slower than f32. */
  precision?: 'f32' | 'int8';
  /** The camera's intrinsics, for frames of its size (default: a generic 60 degree camera for the frames' size, said in the notes). */
  camera?: Intrinsics;
  /** The person's hand: the object of a hand file written by `monohand run --save-hand` (both hands are fitted at its size; the absolute depth scales with it). */
  hand?: HandFile;
  /** A ruler's hand length in mm, the hand flat, from the wrist crease to the end of the middle finger (not with `hand`). */
  handLengthMm?: number;
  /** Each fitted hand's record carries its 26 OpenXR joints, `xr_joints` (default false; as `monohand run --xr-joints`), which {@link webxrJoints} turns into WebXR's. */
  xrJoints?: boolean;
  /** The threads to track on (default 2, or 1 on a one-core machine). More than one needs a cross-origin isolated page (COOP/COEP headers) and a browser with WebAssembly relaxed SIMD (Chrome and Edge 114 or newer); else the tracker runs on one and its notes say why. */
  threads?: number;
}

/** Why this browser cannot run monohand (no WebAssembly, or no WebAssembly SIMD), or `null` if it can. */
export declare function unsupportedReason(): string | null;

/** The weights files the tracker loads by default (MediaPipe 0.10.14's full networks). */
export declare const DEFAULT_WEIGHTS: { readonly palm: string; readonly landmark: string };

/** A frame for {@link Tracker.track}: an `ImageData` (copied) or an `ImageBitmap` or `VideoFrame` (handed over to the tracker's worker, which closes it). */
export type Frame = ImageData | ImageBitmap | VideoFrame;

/** A tracking session over the page's frames, run in a Web Worker. Made by {@link createTracker}. */
export declare class Tracker {
  private constructor(worker: Worker, threads: number, notes: string[]);
  /** The threads the tracker runs on (1 unless the page is cross-origin isolated). */
  readonly threads: number;
  /**
   * Tracks the hands of one frame at `timeS` seconds, later than the last frame's.
   * Resolves with the records of the frames now done (this one); calls are answered in
   * order, and the page's thread is free meanwhile. Rejects with an `Error` whose message
   * says what is wrong for a frame whose bytes do not match its size.
   */
  track(frame: Frame, timeS: number): Promise<FrameRecord[]>;
  /** The records of the frames still kept back (call once at the end of a video). */
  finish(): Promise<FrameRecord[]>;
  /** Messages for the user since the last call (the camera assumed, for one). */
  notes(): Promise<string[]>;
  /** How many operator evaluations have been shared between threads so far (the operator team: on two threads a network that runs alone shares its large operators between both; 0 on one thread). A diagnostic. */
  sharedOperators(): Promise<number>;
  /** Stops the worker (and its threads); the tracker cannot be used after. */
  close(): void;
}

/**
 * Loads the WebAssembly module and the networks and starts a session in a Web Worker. Rejects with an
 * `Error` whose message says what is wrong: an unsupported browser ({@link unsupportedReason}),
 * weights missing, cut short or of another network (naming the file), bad options.
 */
export declare function createTracker(options?: TrackerOptions): Promise<Tracker>;
