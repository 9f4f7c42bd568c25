// Load a .glb with three.js's GLTFLoader, play its animation with an AnimationMixer, and print
// (as JSON) the world positions of every skin's bones, of sampled skinned vertices and of every
// other animated node, at the given times. Positions are in glTF's frame (+Y up, metres).
// Usage: node three_pose.mjs FILE.glb TIME [TIME ...] [--vertex-step N]
import { readFile } from "node:fs/promises";
import { AnimationMixer, LoopOnce, Vector3 } from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";

const DEFAULT_VERTEX_STEP = 97; // sample every 97th vertex of each skinned mesh

function parseArguments(argv) {
  const [file, ...rest] = argv;
  const stepAt = rest.indexOf("--vertex-step");
  const vertexStep = stepAt >= 0 ? Number(rest.splice(stepAt, 2)[1]) : DEFAULT_VERTEX_STEP;
  return { file, times: rest.map(Number), vertexStep };
}

function loadGlb(bytes) {
  const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  return new Promise((resolve, reject) => new GLTFLoader().parse(buffer, "", resolve, reject));
}

function worldPosition(object) {
  return object.getWorldPosition(new Vector3()).toArray();
}

function skinnedVertex(mesh, index) {
  const vertex = new Vector3().fromBufferAttribute(mesh.geometry.attributes.position, index);
  mesh.applyBoneTransform(index, vertex);
  return vertex.applyMatrix4(mesh.matrixWorld).toArray();
}

const { file, times, vertexStep } = parseArguments(process.argv.slice(2));
if (!file || times.length === 0 || times.some(Number.isNaN)) {
  console.error("usage: node three_pose.mjs FILE.glb TIME [TIME ...] [--vertex-step N]");
  process.exit(2);
}
const gltf = await loadGlb(await readFile(file));
const mixer = new AnimationMixer(gltf.scene);
for (const clip of gltf.animations) {
  // Play once and hold the last pose: a looping action would wrap the clip's end back to its start.
  const action = mixer.clipAction(clip).setLoop(LoopOnce, 1);
  action.clampWhenFinished = true;
  action.play();
}

const skinned = [];
gltf.scene.traverse((object) => { if (object.isSkinnedMesh) skinned.push(object); });
const animatedNames = new Set(gltf.animations.flatMap((clip) => clip.tracks.map((track) => track.name.split(".")[0])));
const boneNames = new Set(skinned.flatMap((mesh) => mesh.skeleton.bones.map((bone) => bone.name)));
const others = [...animatedNames].filter((name) => !boneNames.has(name)).sort();

const skins = skinned.map((mesh) => {
  const count = mesh.geometry.attributes.position.count;
  const vertices = Array.from({ length: Math.ceil(count / vertexStep) }, (_, k) => k * vertexStep);
  return { name: mesh.name, bones: mesh.skeleton.bones.map((bone) => bone.name), vertices, bonePositions: [], vertexPositions: [] };
});
const nodes = others.map((name) => ({ name, positions: [] }));
for (const time of times) {
  mixer.setTime(time);
  gltf.scene.updateMatrixWorld(true);
  skinned.forEach((mesh, k) => {
    mesh.skeleton.update();
    skins[k].bonePositions.push(mesh.skeleton.bones.map(worldPosition));
    skins[k].vertexPositions.push(skins[k].vertices.map((index) => skinnedVertex(mesh, index)));
  });
  nodes.forEach((node) => node.positions.push(worldPosition(gltf.scene.getObjectByName(node.name))));
}
console.log(JSON.stringify({ times, skins, nodes }));
