// draw.html's script: loads the GLB with three.js's GLTFLoader, frames it, lights it, renders
// one frame and leaves the pixels in window.result (see draw.html for the query).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const query = new URLSearchParams(location.search);

function vector(text, fallback) {
    if (!text) return fallback;
    const v = text.split(',').map(Number);
    if (v.length !== 3 || !v.every(Number.isFinite) || v.every((x) => x === 0)) {
        throw new Error(`dir=${text}: want three numbers, not all zero`);
    }
    return new THREE.Vector3(...v);
}

function base64(bytes) {
    let text = '';
    for (let i = 0; i < bytes.length; i += 0x8000) {
        text += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
    }
    return btoa(text);
}

/// What GLTFLoader made of each material: the tests check that the textures reached three.js.
function describeMaterial(m) {
    const map = (t) => (t ? {
        width: t.image ? t.image.width : null,
        height: t.image ? t.image.height : null,
        colorSpace: t.colorSpace,
        channel: t.channel,
    } : null);
    return {
        name: m.name,
        type: m.type,
        color: m.color ? m.color.toArray() : null,
        metalness: m.metalness,
        roughness: m.roughness,
        map: map(m.map),
        normalMap: map(m.normalMap),
        metalnessMap: map(m.metalnessMap),
        roughnessMap: map(m.roughnessMap),
        aoMap: map(m.aoMap),
        emissiveMap: map(m.emissiveMap),
    };
}

async function draw() {
    const file = query.get('glb');
    if (!file) throw new Error('no ?glb=NAME.glb in the page address');
    const size = Number(query.get('size') || 256);
    const dir = vector(query.get('dir'), new THREE.Vector3(0, 0, 1)).normalize();
    const bg = query.get('bg') || 'ff00ff';
    if (!/^[0-9a-fA-F]{6}$/.test(bg)) throw new Error(`bg=${bg}: want RRGGBB`);
    const background = [0, 2, 4].map((i) => parseInt(bg.slice(i, i + 2), 16));

    const gltf = await new GLTFLoader().loadAsync(file);
    const model = gltf.scene;
    const scene = new THREE.Scene();
    scene.background = new THREE.Color(`#${bg}`);
    scene.add(model);
    model.updateMatrixWorld(true);

    const box = new THREE.Box3().setFromObject(model);
    if (box.isEmpty()) throw new Error('the model has no geometry');
    const centre = box.getCenter(new THREE.Vector3());
    const radius = Math.max(box.getBoundingSphere(new THREE.Sphere()).radius, 1e-6);
    const fov = 40;
    // The bounding sphere fits the view, with a margin.
    const distance = (1.1 * radius) / Math.sin(THREE.MathUtils.degToRad(fov / 2));
    const camera = new THREE.PerspectiveCamera(fov, 1, distance / 100, distance + 2 * radius);
    camera.position.copy(centre).addScaledVector(dir, distance);
    if (Math.abs(dir.y) > 0.999) camera.up.set(0, 0, -Math.sign(dir.y));
    camera.lookAt(centre);

    // A soft sky and ground light, and a sun over the viewer's right shoulder.
    scene.add(new THREE.HemisphereLight(0xffffff, 0x666666, 1.5));
    const sun = new THREE.DirectionalLight(0xffffff, 2.0);
    const right = new THREE.Vector3().crossVectors(dir, camera.up).normalize().negate();
    sun.position.copy(centre).addScaledVector(dir, distance)
        .addScaledVector(camera.up, 0.5 * distance).addScaledVector(right, 0.5 * distance);
    sun.target.position.copy(centre);
    scene.add(sun, sun.target);

    const canvas = document.createElement('canvas');
    canvas.width = size;
    canvas.height = size;
    document.body.appendChild(canvas);
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: false,
                                               preserveDrawingBuffer: true });
    renderer.setPixelRatio(1);
    renderer.setSize(size, size, false);
    renderer.render(scene, camera);

    const gl = renderer.getContext();
    const flipped = new Uint8Array(size * size * 4);
    gl.readPixels(0, 0, size, size, gl.RGBA, gl.UNSIGNED_BYTE, flipped);
    // WebGL's rows run bottom to top: turned over, so row 0 is the top of the picture.
    const pixels = new Uint8Array(size * size * 4);
    for (let y = 0; y < size; y++) {
        const row = flipped.subarray((size - 1 - y) * size * 4, (size - y) * size * 4);
        pixels.set(row, y * size * 4);
    }
    const error = gl.getError();
    if (error !== gl.NO_ERROR) throw new Error(`WebGL error ${error}`);
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    const name = info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER;
    const materials = [];
    let meshes = 0;
    model.traverse((o) => {
        if (!o.isMesh) return;
        meshes++;
        for (const m of Array.isArray(o.material) ? o.material : [o.material]) {
            if (!materials.includes(m)) materials.push(m);
        }
    });
    return {
        ok: true,
        width: size,
        height: size,
        pixels: base64(pixels),
        background,
        renderer: gl.getParameter(name),
        scene: {
            meshes,
            triangles: renderer.info.render.triangles,
            calls: renderer.info.render.calls,
            textures: renderer.info.memory.textures,
            box: { min: box.min.toArray(), max: box.max.toArray() },
            materials: materials.map(describeMaterial),
        },
    };
}

draw().then(
    (result) => {
        window.result = result;
        document.title = `drawn ${JSON.stringify(result.scene)}`;
    },
    (e) => {
        window.result = { ok: false, error: String(e && e.stack || e) };
        document.title = `error: ${window.result.error}`;
    },
);
