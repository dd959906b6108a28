// What the demo page's two 3D views share (web/hand3d.js, monohand's skinned hand, and
// web/webxr-hand.js, three.js' WebXR hand): the scene and its lights, the video camera's
// field of view at the origin, and the viewpoint from the side.

import * as THREE from 'three';

/** A renderer on `canvas` (throws if the browser gives no WebGL), a lit scene and a view. */
function makeScene(canvas) {
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
  renderer.setSize(canvas.width, canvas.height, false);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1a1a20);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x445566, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 2.0);
  sun.position.set(0.5, 1, 0.6);
  scene.add(sun);
  const view = new THREE.PerspectiveCamera(35, canvas.width / canvas.height, 0.01, 20);
  return { renderer, scene, view };
}

/** The video camera's field of view, from a record's camera, at the origin (looking down -z). */
function cameraFrustum(cam) {
  const fov = (2 * Math.atan(cam.height / 2 / cam.fy) * 180) / Math.PI;
  return new THREE.CameraHelper(new THREE.PerspectiveCamera(fov, cam.width / cam.height, 0.005, 0.08));
}

/** Points `view` at the hands around `centre` from the right side and a little above, the camera's origin in view. */
function lookFromSide(view, centre) {
  const look = centre.clone().multiplyScalar(0.5);
  const d = Math.max(0.5, centre.length() * 1.7);
  view.position.set(look.x + d, look.y + 0.35 * d, look.z);
  view.lookAt(look);
}

/**
 * A 3D view of hands seen from the side: the scene, the video camera's field of view at the
 * origin (from the first record that has a camera), and a render centred on the hands.
 */
export class SideView {
  /** Draws into `canvas`; throws if the browser gives no WebGL. */
  constructor(canvas) {
    ({ renderer: this.renderer, scene: this.scene, view: this.view } = makeScene(canvas));
    this.frustum = null;
  }

  /** Shows the video camera's field of view at the origin, once, from a record's camera. */
  showCamera(cam) {
    if (this.frustum || !cam) return;
    this.frustum = cameraFrustum(cam);
    this.scene.add(this.frustum);
  }

  /** Renders, seen from the side of the mean of `n` hands' points summed in `sum`. */
  render(sum, n) {
    if (n) lookFromSide(this.view, sum.clone().divideScalar(n));
    this.renderer.render(this.scene, this.view);
  }
}
