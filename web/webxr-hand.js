// The demo page's other 3D view: three.js' own WebXR hand (XRHandModelFactory's 'mesh'
// profile, the WebXR generic hand), written for a headset's hand input, driven by the
// webcam. Each record's hand goes through webxrJoints (web/webxr.js: WebXR's 25 joint
// poses) into a hand space shaped as three.js' `renderer.xr.getHand(i)`, posed the way
// three.js' WebXRController poses it from an XRFrame; three.js' hand model then follows
// it unchanged. The mesh's two .glb files are the project's copy
// (crates/monohand-io/assets/webxr-generic-hand, copied to web/webxr-hand/ by
// scripts/web-build.sh), so nothing is fetched from a CDN.

import * as THREE from 'three';
import { SideView } from './scene3d.js';
import { XRHandModelFactory } from 'three/addons/webxr/XRHandModelFactory.js';
import { WEBXR_JOINT_NAMES, webxrJoints } from './webxr.js';

/**
 * A hand space as three.js gives one in an XR session (`renderer.xr.getHand(i)`): a group
 * with a `joints` object of 25 groups named as WebXR's joints, that says `connected` with
 * an XRInputSource-shaped `data` (its `hand` a Map of joint spaces) when the hand first
 * appears. {@link WebXRHandSpace#update} poses it from a record's hand.
 */
export class WebXRHandSpace extends THREE.Group {
  constructor(handedness) {
    super();
    this.visible = false;
    this.joints = {};
    this.inputState = { pinching: false };
    this.inputSource = {
      handedness,
      hand: new Map(WEBXR_JOINT_NAMES.map((jointName) => [jointName, { jointName }])),
      targetRayMode: 'tracked-pointer',
      profiles: ['generic-hand'],
    };
    for (const name of WEBXR_JOINT_NAMES) {
      const joint = new THREE.Group();
      joint.matrixAutoUpdate = false;
      joint.visible = false;
      this.joints[name] = joint;
      this.add(joint);
    }
    this.connected = false;
  }

  /** Poses the joints from a record's hand (with `xr_joints`); hides them without. */
  update(hand) {
    const poses = webxrJoints(hand);
    if (!poses) {
      this.visible = false;
      return false;
    }
    if (!this.connected) {
      this.connected = true;
      this.dispatchEvent({ type: 'connected', data: this.inputSource });
    }
    // As three.js' WebXRController.update does with each XRJointPose.
    for (const [name, pose] of poses) {
      const joint = this.joints[name];
      joint.matrix.fromArray(pose.transform.matrix);
      joint.matrix.decompose(joint.position, joint.rotation, joint.scale);
      joint.matrixWorldNeedsUpdate = true;
      joint.jointRadius = pose.radius;
      joint.visible = true;
    }
    this.visible = true;
    return true;
  }
}

export class WebXRHandView extends SideView {
  /** Draws into `canvas`; throws if the browser gives no WebGL. */
  constructor(canvas) {
    super(canvas);
    const factory = new XRHandModelFactory().setPath(new URL('./webxr-hand/', import.meta.url).href);
    /** Per side: the hand space and three.js' hand model in it. */
    this.hands = {};
    for (const side of ['left', 'right']) {
      const space = new WebXRHandSpace(side);
      const model = factory.createHandModel(space, 'mesh');
      space.add(model);
      this.scene.add(space);
      this.hands[side] = { space, model };
    }
    /** The largest distance, mm, between a bone of three.js' hand mesh and its WebXR joint. */
    this.maxBoneOffsetMm = 0;
    /** The bones three.js' mesh found by WebXR's names, per side (once loaded). */
    this.bones = {};
  }

  /** Poses and draws the first fitted hand of each side of `frame` (a record). */
  update(frame) {
    this.showCamera(frame.cameras?.[0]);
    const centre = new THREE.Vector3();
    const drawn = [];
    let posed = 0;
    for (const side of ['left', 'right']) {
      const hand = frame.hands.find((h) => h.side === side && h.xr_joints);
      const { space, model } = this.hands[side];
      if (!space.update(hand)) continue;
      centre.add(space.joints.wrist.position);
      posed += 1;
      const bones = model.motionController?.bones ?? [];
      if (bones.length) drawn.push({ side, space, bones });
    }
    this.render(centre, posed);
    // three.js moved its mesh's bones while rendering (XRHandModel.updateMatrixWorld).
    const p = new THREE.Vector3();
    const q = new THREE.Vector3();
    for (const { side, space, bones } of drawn) {
      this.bones[side] = bones.filter(Boolean).length;
      for (const bone of bones.filter(Boolean)) {
        bone.getWorldPosition(p);
        space.joints[bone.jointName].getWorldPosition(q);
        this.maxBoneOffsetMm = Math.max(this.maxBoneOffsetMm, 1000 * p.distanceTo(q));
      }
    }
    return drawn.length;
  }
}
