// The demo page's 3D view: the skinned hand of `monohand run --gltf` (the WebXR generic hand
// mesh laid on the fitted joints by monohand's own code, crates/monohand-web/src/mesh.rs),
// drawn with three.js (web/node_modules, pinned in web/package-lock.json), seen from the
// side, with the video camera's field of view at the origin so that the distance reads.
// Each side's mesh is loaded once, as a binary glTF the module writes; after that each frame
// only moves its 25 joints.

import * as THREE from 'three';
import { SideView } from './scene3d.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import init, { WebHandMesh } from './pkg/monohand_web.js';

// The tracker runs in its worker; the mesh is made on the page's thread, by the one-thread
// module loaded here.
await init();

/** Numbers per mesh joint in WebHandMesh.pose: translation (3), rotation (4), scale. */
const STRIDE = 8;

export class HandView extends SideView {
  /** Draws into `canvas`; throws if the browser gives no WebGL. */
  constructor(canvas) {
    super(canvas);
    this.mesh = new WebHandMesh();
    this.loader = new GLTFLoader();
    /** Per side: a promise while loading, then { root, bones }. */
    this.hands = { left: null, right: null };
  }

  /** Loads the skinned mesh of `hand`'s side from a glTF of this hand alone. */
  async load(frame, hand) {
    const bytes = this.mesh.glb(JSON.stringify({ ...frame, hands: [hand] }));
    const gltf = await this.loader.parseAsync(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength), '');
    let skinned = null;
    gltf.scene.traverse((o) => {
      if (o.isSkinnedMesh) skinned = o;
      o.frustumCulled = false;
    });
    if (!skinned) throw new Error('the glTF has no skinned hand');
    this.scene.add(gltf.scene);
    return { root: gltf.scene, bones: skinned.skeleton.bones };
  }

  /** Poses and draws the first fitted hand of each side of `frame` (a record). */
  update(frame) {
    this.showCamera(frame.cameras?.[0]);
    const centre = new THREE.Vector3();
    let shown = 0;
    for (const side of ['left', 'right']) {
      const hand = frame.hands.find((h) => h.side === side && h.joints_3d_mm);
      const entry = this.hands[side];
      if (!hand || !entry || entry instanceof Promise) {
        if (entry && !(entry instanceof Promise)) entry.root.visible = false;
        if (hand && !entry) {
          this.hands[side] = this.load(frame, hand).then((h) => { this.hands[side] = h; },
            (e) => { this.hands[side] = null; console.warn(`3D view: ${e.message}`); });
        }
        continue;
      }
      const p = this.mesh.pose(side, Float64Array.from(hand.joints_3d_mm.flat()));
      entry.root.visible = p.length > 0;
      if (!p.length) continue;
      entry.bones.forEach((bone, k) => {
        const o = k * STRIDE;
        bone.position.set(p[o], p[o + 1], p[o + 2]);
        bone.quaternion.set(p[o + 3], p[o + 4], p[o + 5], p[o + 6]);
        bone.scale.setScalar(p[o + 7]);
      });
      centre.add(new THREE.Vector3(p[0], p[1], p[2]));
      shown += 1;
    }
    this.render(centre, shown);
    return shown;
  }
}
