// The overlay of the demo page, drawn on a 2D canvas from `run`'s records: the fitted 3D
// hand as depth-shaded bones (nearer over farther, lit from the upper left, farther parts
// darker), each hand's label with its distance from the camera, and a top view (the x-z
// plane, the camera at the bottom, a millimetre scale), as `monohand run --overlay` draws
// them (crates/monohand-media/src/scene.rs). The colours, radii and shading constants are
// that file's and monohand-io's palette.rs; change them there and here together.

/** MediaPipe's bones, as index pairs into the 21 joints. */
export const BONES = [[0, 1], [1, 2], [2, 3], [3, 4], [0, 5], [5, 6], [6, 7], [7, 8], [0, 9],
  [9, 10], [10, 11], [11, 12], [0, 13], [13, 14], [14, 15], [15, 16], [0, 17], [17, 18],
  [18, 19], [19, 20]];

/** Thumb, index, middle, ring, little (monohand_io::palette::FINGER_COLORS). */
const FINGER_COLORS = [[255, 70, 70], [255, 210, 0], [60, 220, 60], [0, 170, 255], [210, 90, 255]];
/** The side's colour: cyan for left, orange for right (monohand_io::palette::side_color). */
const SIDE_COLORS = { left: [0, 230, 255], right: [255, 140, 0] };
/** Direction towards the light in the camera frame (upper left, in front). */
const LIGHT = (() => {
  const l = [-0.45, -0.65, -0.61];
  const n = Math.hypot(...l);
  return l.map((v) => v / n);
})();
const AMBIENT = 0.32;
const DIFFUSE = 0.68;
const SPECULAR = 0.35;
/** Depth over which a hand's farthest parts darken, mm, and by how much. */
const DEPTH_CUE_MM = 120;
const DEPTH_CUE = 0.35;

const rgb = (c, k = 1, add = 0) => `rgb(${c.map((v) => Math.min(255, Math.round(v * k + add))).join(',')})`;
const sideColor = (side) => SIDE_COLORS[side] ?? [220, 220, 220];
const boneColor = (hand, a, b) => (a === 0 ? sideColor(hand.side) : FINGER_COLORS[Math.floor((b - 1) / 4)]);

/** Radius of the model's capsule at a joint, mm (scene.rs' joint_radius_mm). */
export function jointRadiusMm(j) {
  if (j === 0 || j === 1) return 10;
  return 9 - ((j - 1) % 4);
}

/** Distance of a hand from the camera, mm: the norm of the palm's centre (scene.rs). */
export function handDistanceMm(joints) {
  const palm = [0, 1, 5, 9, 13, 17];
  const c = [0, 0, 0];
  for (const j of palm) for (let k = 0; k < 3; k++) c[k] += joints[j][k] / palm.length;
  return Math.hypot(...c);
}

/** A hand's label: `R#3 0.97 42CM` (side, id, score, distance), as the CLI's. */
export function handLabel(hand) {
  let s = hand.side === 'left' ? 'L' : 'R';
  if (hand.id !== undefined) s += `#${hand.id}`;
  if (Number.isFinite(hand.score)) s += ` ${hand.score.toFixed(2)}`;
  if (hand.joints_3d_mm) {
    const d = handDistanceMm(hand.joints_3d_mm);
    if (Number.isFinite(d)) s += ` ${(d / 10).toFixed(0)}CM`;
  }
  return s;
}

/** The frame's camera (the record's first), else the generic 60 degree one for the size. */
function cameraOf(frame, w, h) {
  const c = frame.cameras?.[0];
  if (c) return c;
  const f = (0.5 * w) / Math.tan(Math.PI / 6);
  return { fx: f, fy: f, cx: (w - 1) / 2, cy: (h - 1) / 2, width: w, height: h };
}

const project = (cam, p) => (p[2] > 1e-6 ? [cam.fx * p[0] / p[2] + cam.cx, cam.fy * p[1] / p[2] + cam.cy] : null);

/** The shading of a sphere's point with normal `n` at depth cue `cue`. */
function shade(n, cue) {
  const diffuse = Math.max(0, n[0] * LIGHT[0] + n[1] * LIGHT[1] + n[2] * LIGHT[2]);
  const h = [LIGHT[0], LIGHT[1], LIGHT[2] - 1];
  const hn = Math.hypot(...h);
  const spec = Math.max(0, (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / hn) ** 24;
  return { k: (AMBIENT + DIFFUSE * diffuse) * cue, add: 255 * SPECULAR * spec };
}

/**
 * Draws the fitted hands as shaded capsules, every hand's bones sorted far to near so that
 * nearer parts cover farther ones. Each capsule is filled with a gradient across it: the
 * sphere shading of its cross-section under the light, darkened with depth.
 */
function drawBones(ctx, frame, cam) {
  const f = 0.5 * (cam.fx + cam.fy);
  const parts = [];
  for (const hand of frame.hands) {
    const joints = hand.joints_3d_mm;
    if (!joints) continue;
    const balls = joints.map((p, j) => {
      const q = project(cam, p);
      if (!q) return null;
      return { c: q, r: (f * jointRadiusMm(j)) / p[2], z: p[2], rmm: jointRadiusMm(j) };
    });
    const near = Math.min(...balls.filter(Boolean).map((b) => b.z - b.rmm));
    for (const [a, b] of BONES) {
      if (balls[a] && balls[b]) parts.push({ a: balls[a], b: balls[b], color: boneColor(hand, a, b), near });
    }
  }
  parts.sort((p, q) => (q.a.z + q.b.z) - (p.a.z + p.b.z));
  for (const { a, b, color, near } of parts) {
    const z = 0.5 * (a.z + b.z) - 0.5 * (a.rmm + b.rmm);
    const cue = 1 - DEPTH_CUE * Math.min(1, Math.max(0, (z - near) / DEPTH_CUE_MM));
    const [dx, dy] = [b.c[0] - a.c[0], b.c[1] - a.c[1]];
    const len = Math.hypot(dx, dy) || 1;
    // The unit normal across the bone, on the light's side.
    let [nx, ny] = [-dy / len, dx / len];
    if (nx * LIGHT[0] + ny * LIGHT[1] < 0) [nx, ny] = [-nx, -ny];
    const r = 0.5 * (a.r + b.r);
    const [mx, my] = [0.5 * (a.c[0] + b.c[0]), 0.5 * (a.c[1] + b.c[1])];
    const g = ctx.createLinearGradient(mx + nx * r, my + ny * r, mx - nx * r, my - ny * r);
    for (const t of [0, 0.2, 0.4, 0.5, 0.6, 0.8, 1]) {
      // The cross-section's normal at this point across: from the light's side (t = 0)
      // through the front (t = 0.5) to the far side.
      const s = 1 - 2 * t;
      const hz = Math.sqrt(Math.max(0, 1 - s * s));
      const sh = shade([nx * s, ny * s, -hz], cue);
      g.addColorStop(t, rgb(color, sh.k, sh.add));
    }
    ctx.fillStyle = g;
    ctx.beginPath();
    ctx.moveTo(a.c[0] + nx * a.r, a.c[1] + ny * a.r);
    ctx.lineTo(b.c[0] + nx * b.r, b.c[1] + ny * b.r);
    ctx.lineTo(b.c[0] - nx * b.r, b.c[1] - ny * b.r);
    ctx.lineTo(a.c[0] - nx * a.r, a.c[1] - ny * a.r);
    ctx.closePath();
    ctx.fill();
    for (const ball of [a, b]) {
      const sh = shade([0, 0, -1], cue);
      const rg = ctx.createRadialGradient(ball.c[0] + LIGHT[0] * ball.r * 0.5, ball.c[1] + LIGHT[1] * ball.r * 0.5,
        0, ball.c[0], ball.c[1], ball.r);
      rg.addColorStop(0, rgb(color, sh.k, sh.add));
      rg.addColorStop(1, rgb(color, AMBIENT * cue));
      ctx.fillStyle = rg;
      ctx.beginPath();
      ctx.arc(ball.c[0], ball.c[1], ball.r, 0, 2 * Math.PI);
      ctx.fill();
    }
  }
}

/** The 2D keypoints of hands without 3D: thin bones in the finger colours. */
function drawKeypoints(ctx, hand, k) {
  ctx.lineWidth = 2 * k;
  for (const [a, b] of BONES) {
    const [p, q] = [hand.keypoints_2d[a], hand.keypoints_2d[b]];
    if (!(p[2] > 0 && q[2] > 0)) continue;
    ctx.strokeStyle = rgb(boneColor(hand, a, b));
    ctx.beginPath();
    ctx.moveTo(p[0], p[1]);
    ctx.lineTo(q[0], q[1]);
    ctx.stroke();
  }
}

function drawLabel(ctx, hand, cam, k, placed) {
  const pts = hand.joints_3d_mm ? hand.joints_3d_mm.map((p) => project(cam, p)).filter(Boolean)
    : hand.keypoints_2d.filter((p) => p[2] > 0);
  if (!pts.length) return;
  const text = handLabel(hand);
  ctx.font = `bold ${Math.round(14 * k)}px sans-serif`;
  const w = ctx.measureText(text).width + 8 * k;
  const h = 20 * k;
  const x = Math.max(0, Math.min(...pts.map((p) => p[0])));
  let y = Math.max(0, Math.min(...pts.map((p) => p[1])) - h - 12);
  // Clear of the labels placed already (moved up past each, or down once up is off).
  for (const box of placed) {
    if (x < box[2] && x + w > box[0] && y < box[3] && y + h > box[1]) {
      y = box[1] - 2 - h >= 0 ? box[1] - 2 - h : box[3] + 2;
    }
  }
  placed.push([x, y, x + w, y + h]);
  ctx.fillStyle = rgb(sideColor(hand.side));
  ctx.fillRect(x, y, w, h);
  ctx.fillStyle = '#000';
  ctx.textBaseline = 'middle';
  ctx.fillText(text, x + 4 * k, y + h / 2);
}

/** A round number at least `v`: 1, 1.5, 2, 2.5, 3, 5 or 7.5 times a power of ten. */
function niceCeil(v) {
  const p = 10 ** Math.floor(Math.log10(Math.max(v, 1e-9)));
  return [1, 1.5, 2, 2.5, 3, 5, 7.5, 10].map((m) => m * p).find((c) => c >= v) ?? 10 * p;
}

/** The top view: bottom right, 30% of the smaller side, depth lines labelled in mm. */
function drawTopView(ctx, frame, cam, w, h, k) {
  const side = Math.max(60, Math.round(0.3 * Math.min(w, h)));
  const margin = Math.max(4, Math.round(Math.min(w, h) * 0.02));
  const [x0, y0] = [w - margin - side, h - margin - side];
  let far = 500;
  for (const hand of frame.hands) for (const p of hand.joints_3d_mm ?? []) far = Math.max(far, p[2] * 1.15);
  const zMax = niceCeil(far);
  const pad = 6 * k;
  const textH = 7 * Math.max(1, Math.round(k)) + 2;
  const scale = (side - 2 * pad - textH) / zMax;
  const step = niceCeil(zMax / 4);
  const px = (x, z) => [x0 + side / 2 + x * scale, y0 + side - pad - z * scale];
  ctx.save();
  ctx.fillStyle = 'rgba(16,16,20,0.72)';
  ctx.fillRect(x0, y0, side, side);
  ctx.strokeStyle = 'rgb(150,150,150)';
  ctx.lineWidth = 1;
  ctx.strokeRect(x0 + 0.5, y0 + 0.5, side - 1, side - 1);
  ctx.beginPath();
  ctx.rect(x0 + 1, y0 + 1, side - 2, side - 2);
  ctx.clip();
  ctx.font = `${Math.round(9 * k)}px sans-serif`;
  ctx.textBaseline = 'top';
  for (let z = step; z <= zMax + 1e-9; z += step) {
    const y = Math.round(px(0, z)[1]) + 0.5;
    ctx.strokeStyle = 'rgb(90,90,90)';
    ctx.beginPath();
    ctx.moveTo(x0 + 2, y);
    ctx.lineTo(x0 + side - 2, y);
    ctx.stroke();
    ctx.fillStyle = 'rgb(170,170,170)';
    ctx.fillText(z.toFixed(0), x0 + 3, y + 2);
  }
  ctx.fillStyle = 'rgb(200,200,200)';
  ctx.fillText('TOP, MM', x0 + 3, y0 + 3);
  // The camera and the edges of its field of view.
  const c = px(0, 0);
  ctx.strokeStyle = 'rgb(120,120,160)';
  for (const u of [0, cam.width - 1]) {
    const e = px(((u - cam.cx) / cam.fx) * 2 * zMax, 2 * zMax);
    ctx.beginPath();
    ctx.moveTo(c[0], c[1]);
    ctx.lineTo(e[0], e[1]);
    ctx.stroke();
  }
  ctx.fillStyle = 'rgb(230,230,230)';
  ctx.beginPath();
  ctx.arc(c[0], c[1], 2.5 * k, 0, 2 * Math.PI);
  ctx.fill();
  // The hands from above.
  ctx.lineWidth = 1.5 * k;
  for (const hand of frame.hands) {
    const j = hand.joints_3d_mm;
    if (!j) continue;
    for (const [a, b] of BONES) {
      const [p, q] = [px(j[a][0], j[a][2]), px(j[b][0], j[b][2])];
      ctx.strokeStyle = rgb(boneColor(hand, a, b));
      ctx.beginPath();
      ctx.moveTo(p[0], p[1]);
      ctx.lineTo(q[0], q[1]);
      ctx.stroke();
    }
    const p = px(j[0][0], j[0][2]);
    ctx.fillStyle = rgb(sideColor(hand.side));
    ctx.beginPath();
    ctx.arc(p[0], p[1], 2 * k, 0, 2 * Math.PI);
    ctx.fill();
  }
  ctx.restore();
}

/**
 * Draws one record's overlay on `ctx`, over the frame already drawn there: shaded bones,
 * the 2D keypoints of hands without 3D, labels with distances, the top view.
 */
export function drawOverlay(ctx, frame) {
  const { width: w, height: h } = ctx.canvas;
  const k = Math.min(4, Math.max(0.5, Math.max(w, h) / 640));
  const cam = cameraOf(frame, w, h);
  drawBones(ctx, frame, cam);
  for (const hand of frame.hands) if (!hand.joints_3d_mm) drawKeypoints(ctx, hand, k);
  const placed = [];
  for (const hand of frame.hands) drawLabel(ctx, hand, cam, k, placed);
  drawTopView(ctx, frame, cam, w, h, k);
}
