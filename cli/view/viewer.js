// vinci view: draws a scene with three.js and plays its trajectory. Embedded in the page that
// `vinci view` writes (cli/view_command.cc), after three.min.js and OrbitControls.js.
//
// Data: the JSON object in <script id="vinci-data"> (cli/view_data.cc, WriteViewJson):
//   format      "vinci-view-1"
//   sources     {scene, trajectory, field}: the input file names (null if absent)
//   scene       {name, dim (2|3), gravity [3], dt, duration, bodies: [{name, kind
//               ("dynamic"|"static"|"prescribed"), p [3], q [w,x,y,z] (initial pose), shapes:
//               [{type (scene-file keyword), name, p, q (pose in the body frame), radius,
//               half_extents [3], half_length, exponent, material, vertices [[3]...],
//               faces [[i...]...] (polyhedron hull, counter-clockwise about the outward
//               normal)}]}]}
//   trajectory  null or {rows (in the CSV), frames, step [frames], t [frames] (s), poses: per
//               body a flat array, per frame planar x,y,theta or spatial x,y,z,qw,qx,qy,qz;
//               report: null or {contacts, iterations, residual, min_gap, status (index into
//               status_names): [frames], aggregated over the rows since the previous frame
//               (max, max, max, min, first unusual); flagged: [{step, t, status}] (rows whose
//               status is neither solved nor initial, first 500), num_flagged}}
//   field       null or {plate, part (body names), spacing (m), normal [3] (plate normal,
//               world), points: [{p [3], v [3] (world, m/s), omega, left_plate, failed}]}
// New kinds of results (a design's best trajectory, a plan's paths) are new members of this
// object with a drawing function below; the page ignores members it does not know.
//
// The page opens paused at the time in its URL fragment (#t=1.8, default 0; also &follow=BODY,
// &field=0 to hide the field, &play to start playing). When the first
// frame has been drawn, <body data-vinci-state="ready" data-vinci-time="T"> (T: the time of the
// frame drawn last); any error sets
// data-vinci-state="error" (see viewer.html); the browser test checks this.
(function () {
  'use strict';

  const $ = (id) => document.getElementById(id);
  // three.js r111 (Debian) names the buffer geometries *BufferGeometry; later releases drop it.
  const Geometry = (name) => THREE[name + 'BufferGeometry'] || THREE[name + 'Geometry'];

  const kDynamicColors = [0xe8833a, 0x3a9ad9, 0x4caf50, 0x9c5fc7, 0xd94c6a, 0x2bb5a6, 0xc9a227,
                          0x6d7fd6];
  const kStaticColor = 0xa7adb4;
  const kPrescribedColor = 0x5a7d9a;
  const kEdgeColor = 0x333333;

  function main() {
    if (typeof THREE === 'undefined') throw new Error('three.js did not load');
    if (typeof THREE.OrbitControls === 'undefined') throw new Error('OrbitControls did not load');
    const data = JSON.parse($('vinci-data').textContent);
    if (data.format !== 'vinci-view-1') throw new Error('unknown data format ' + data.format);
    const viewer = new Viewer(data);
    window.vinciView = viewer;  // for the console
    viewer.start();
  }

  // ---- geometry ----------------------------------------------------------------------------

  function v3(a) { return new THREE.Vector3(a[0], a[1], a[2]); }
  function quat(q) { return new THREE.Quaternion(q[1], q[2], q[3], q[0]).normalize(); }

  // Colours a geometry's vertices by octant of the shape frame (base and a lighter tint of the
  // same hue), so that rotations of round shapes are visible.
  function octantColors(geometry, color) {
    const pos = geometry.getAttribute('position');
    const light = color.clone().lerp(new THREE.Color(0xffffff), 0.45);
    const colors = new Float32Array(pos.count * 3);
    for (let i = 0; i < pos.count; ++i) {
      const s = (pos.getX(i) >= 0) ^ (pos.getY(i) >= 0) ^ (pos.getZ(i) >= 0);
      const c = s ? light : color;
      colors[3 * i] = c.r; colors[3 * i + 1] = c.g; colors[3 * i + 2] = c.b;
    }
    geometry.setAttribute('color', new THREE.BufferAttribute(colors, 3));
    return true;
  }

  // A lathe (profile in (radius, height) revolved about y) turned so that the axis is z.
  function latheZ(profile, segments) {
    const g = new (Geometry('Lathe'))(profile.map((p) => new THREE.Vector2(p[0], p[1])), segments);
    g.rotateX(Math.PI / 2);
    return g;
  }

  function signedPow(x, p) { return Math.sign(x) * Math.pow(Math.abs(x), p); }

  // Surface |x/a|^e + |y/b|^e + |z/c|^e = 1: a unit sphere's points mapped by sgn(u)|u|^(2/e).
  function superquadric(a, b, c, e) {
    const g = new (Geometry('Sphere'))(1, 64, 32);
    const pos = g.getAttribute('position');
    const p = 2 / e;
    for (let i = 0; i < pos.count; ++i) {
      pos.setXYZ(i, a * signedPow(pos.getX(i), p), b * signedPow(pos.getY(i), p),
                 c * signedPow(pos.getZ(i), p));
    }
    g.computeVertexNormals();
    return g;
  }

  function polyhedron(shape) {
    const verts = shape.vertices, faces = shape.faces || [];
    const pos = [], nrm = [];
    for (const f of faces) {
      const a = v3(verts[f[0]]);
      for (let k = 1; k + 1 < f.length; ++k) {
        const b = v3(verts[f[k]]), c = v3(verts[f[k + 1]]);
        const n = new THREE.Vector3().subVectors(b, a).cross(new THREE.Vector3().subVectors(c, a))
                      .normalize();
        for (const p of [a, b, c]) { pos.push(p.x, p.y, p.z); nrm.push(n.x, n.y, n.z); }
      }
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
    g.setAttribute('normal', new THREE.Float32BufferAttribute(nrm, 3));
    return g;
  }

  // The outline of a planar shape as a THREE.Shape (null for a bare segment).
  function outline2d(shape, extent) {
    const s = new THREE.Shape();
    const r = shape.radius, hl = shape.half_length;
    const a = shape.half_extents[0], b = shape.half_extents[1];
    switch (shape.type) {
      case 'disc':
        s.absarc(0, 0, r, 0, 2 * Math.PI, false);
        return s;
      case 'ellipse':
        s.absellipse(0, 0, a, b, 0, 2 * Math.PI, false, 0);
        return s;
      case 'superellipse': {
        const n = 128, p = 2 / shape.exponent;
        for (let i = 0; i < n; ++i) {
          const th = 2 * Math.PI * i / n;
          const x = a * signedPow(Math.cos(th), p), y = b * signedPow(Math.sin(th), p);
          if (i === 0) s.moveTo(x, y); else s.lineTo(x, y);
        }
        return s;
      }
      case 'polygon':
      case 'concave_polygon':
        shape.vertices.forEach((v, i) => (i === 0 ? s.moveTo(v[0], v[1]) : s.lineTo(v[0], v[1])));
        return s;
      case 'segment':
        if (!(r > 0)) return null;
        s.moveTo(-hl, -r);
        s.lineTo(hl, -r);
        s.absarc(hl, 0, r, -Math.PI / 2, Math.PI / 2, false);
        s.lineTo(-hl, r);
        s.absarc(-hl, 0, r, Math.PI / 2, 3 * Math.PI / 2, false);
        return s;
      case 'halfplane': {
        // {y <= 0}, drawn as a finite band under the scene.
        const L = extent.size * 3, cx = extent.centerInShape.x;
        s.moveTo(cx - L / 2, -L / 3);
        s.lineTo(cx + L / 2, -L / 3);
        s.lineTo(cx + L / 2, 0);
        s.lineTo(cx - L / 2, 0);
        return s;
      }
    }
    return undefined;
  }

  // A rough radius of a shape about its frame origin, for framing the camera.
  function shapeRadius(shape) {
    const he = shape.half_extents;
    switch (shape.type) {
      case 'halfspace': case 'halfplane': return 0;
      case 'sphere': case 'disc': return shape.radius;
      case 'box': case 'ellipsoid': case 'superquadric': case 'ellipse': case 'superellipse':
        return Math.hypot(he[0], he[1], he[2]);
      case 'capsule': case 'segment': case 'cylinder':
        return shape.half_length + shape.radius;
      case 'lens': return shape.radius;
      default: {
        let r = 0;
        for (const v of shape.vertices || []) r = Math.max(r, Math.hypot(v[0], v[1], v[2]));
        return r;
      }
    }
  }

  // ---- the viewer --------------------------------------------------------------------------

  class Viewer {
    constructor(data) {
      this.data = data;
      this.sceneData = data.scene;
      this.planar = data.scene.dim === 2;
      this.traj = data.trajectory;
      this.bodies = data.scene.bodies;
      this.t0 = this.traj ? this.traj.t[0] : 0;
      this.t1 = this.traj ? this.traj.t[this.traj.t.length - 1] : 0;
      this.time = this.t0;
      this.playing = false;
      this.speed = 1;
      this.follow = -1;
      this.dirty = true;
      this.poseSize = this.planar ? 3 : 7;
      this.frameIndex = 0;

      const g = v3(data.scene.gravity);
      this.up = g.lengthSq() > 0 ? g.clone().normalize().negate()
                                 : (this.planar ? new THREE.Vector3(0, 1, 0)
                                                : new THREE.Vector3(0, 0, 1));
      this.extent = this.computeExtent();

      this.renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
      this.renderer.setPixelRatio(1);
      this.renderer.setClearColor(0xeef1f5, 1);
      $('view').appendChild(this.renderer.domElement);
      this.scene = new THREE.Scene();
      // Sky light from "up" (planar: from the viewer, +z), a sun from above the viewer's right.
      const hemi = new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 0.75);
      const sun = new THREE.DirectionalLight(0xffffff, 0.65);
      if (this.planar) {
        hemi.position.set(0, 0, 1);
        hemi.intensity = 0.55;
        sun.position.set(0.3, 0.6, 1);
        sun.intensity = 0.35;
      } else {
        hemi.position.copy(this.up);
        sun.position.copy(this.up.clone().multiplyScalar(2).add(new THREE.Vector3(0.7, -0.9, 0.4)));
      }
      this.scene.add(hemi);
      this.scene.add(sun);

      this.groups = this.bodies.map((b, i) => this.buildBody(b, i));
      this.groups.forEach((grp) => this.scene.add(grp));
      if (data.field) this.buildField(data.field);
      this.setupCamera();
      this.setupControls();
      this.setupPlot();
      window.addEventListener('resize', () => this.resize());
      this.resize();
    }

    // Pose (position, quaternion) of body i at the current time.
    bodyPose(i, pos, q) {
      const tr = this.traj;
      if (!tr) {
        pos.copy(v3(this.bodies[i].p));
        q.copy(quat(this.bodies[i].q));
        return;
      }
      const { k, a } = this.locate(this.time);
      const P = tr.poses[i], n = this.poseSize;
      const k1 = Math.min(k + 1, tr.t.length - 1);
      if (this.planar) {
        const lerp = (j) => P[k * n + j] * (1 - a) + P[k1 * n + j] * a;
        pos.set(lerp(0), lerp(1), 0);
        q.setFromAxisAngle(new THREE.Vector3(0, 0, 1), lerp(2));
      } else {
        const lerp = (j) => P[k * n + j] * (1 - a) + P[k1 * n + j] * a;
        pos.set(lerp(0), lerp(1), lerp(2));
        const qa = new THREE.Quaternion(P[k * n + 4], P[k * n + 5], P[k * n + 6], P[k * n + 3]);
        const qb = new THREE.Quaternion(P[k1 * n + 4], P[k1 * n + 5], P[k1 * n + 6], P[k1 * n + 3]);
        qa.normalize();
        qb.normalize();
        q.copy(qa).slerp(qb, a);
      }
    }

    // Frame k and weight a with t between t[k] and t[k+1].
    locate(t) {
      const T = this.traj.t;
      if (t <= T[0]) return { k: 0, a: 0 };
      if (t >= T[T.length - 1]) return { k: T.length - 1, a: 0 };
      let lo = 0, hi = T.length - 1;
      while (hi - lo > 1) {
        const mid = (lo + hi) >> 1;
        if (T[mid] <= t) lo = mid; else hi = mid;
      }
      const span = T[hi] - T[lo];
      return { k: lo, a: span > 0 ? (t - T[lo]) / span : 0 };
    }

    // Bounding box of everything finite over the whole trajectory: {box, center, size,
    // centerInShape (set per half-space)}.
    computeExtent() {
      const box = new THREE.Box3();
      const pos = new THREE.Vector3(), q = new THREE.Quaternion();
      const frames = this.traj ? this.traj.t.length : 1;
      this.bodies.forEach((b, i) => {
        let r = 0;
        for (const s of b.shapes) r = Math.max(r, shapeRadius(s) + v3(s.p).length());
        if (r === 0) return;  // only half-spaces
        for (let k = 0; k < frames; ++k) {
          if (this.traj) {
            const P = this.traj.poses[i], n = this.poseSize;
            pos.set(P[k * n], P[k * n + 1], this.planar ? 0 : P[k * n + 2]);
          } else {
            pos.copy(v3(b.p));
          }
          box.expandByPoint(pos.clone().addScalar(r));
          box.expandByPoint(pos.clone().addScalar(-r));
        }
      });
      if (this.data.field) for (const p of this.data.field.points) box.expandByPoint(v3(p.p));
      if (box.isEmpty()) box.set(new THREE.Vector3(-1, -1, -1), new THREE.Vector3(1, 1, 1));
      const size = Math.max(box.getSize(new THREE.Vector3()).length(), 1e-6);
      return { box, center: box.getCenter(new THREE.Vector3()), size };
    }

    buildBody(b, index) {
      const grp = new THREE.Group();
      grp.name = b.name;
      let color;
      if (b.kind === 'static') color = kStaticColor;
      else if (b.kind === 'prescribed') color = kPrescribedColor;
      else {
        const dyn = this.bodies.slice(0, index).filter((x) => x.kind === 'dynamic').length;
        color = kDynamicColors[dyn % kDynamicColors.length];
      }
      const X_WB = new THREE.Matrix4().compose(v3(b.p), quat(b.q), new THREE.Vector3(1, 1, 1));
      for (const s of b.shapes) {
        const obj = this.buildShape(s, new THREE.Color(color), X_WB);
        obj.position.copy(v3(s.p));
        obj.quaternion.copy(quat(s.q));
        grp.add(obj);
      }
      return grp;
    }

    // One shape as an Object3D in its shape frame.
    buildShape(s, color, X_WB) {
      const ext = this.extent;
      // The scene's centre in the shape frame at the initial pose (to centre finite planes).
      const X_WS = X_WB.clone().multiply(
          new THREE.Matrix4().compose(v3(s.p), quat(s.q), new THREE.Vector3(1, 1, 1)));
      const X_SW = X_WS.invert ? X_WS.clone().invert() : new THREE.Matrix4().getInverse(X_WS);
      const centerInShape = ext.center.clone().applyMatrix4(X_SW);
      const he = s.half_extents;
      let geom = null, smooth = false, flat = false;
      if (this.planar) {
        const th = ext.size * 0.02;
        const outline = outline2d(s, { size: ext.size, centerInShape });
        if (outline === undefined) throw new Error('unknown planar shape type ' + s.type);
        if (outline === null) {  // a bare segment: a thin bar on top of the extruded shapes
          const bar = new THREE.Mesh(new (Geometry('Plane'))(2 * s.half_length, ext.size * 0.006),
                                     new THREE.MeshBasicMaterial({ color }));
          bar.geometry.translate(0, 0, th);
          return bar;
        }
        geom = new (Geometry('Extrude'))(outline, { depth: th, bevelEnabled: false,
                                                    curveSegments: 48 });
        geom.translate(0, 0, -th / 2);
        flat = s.type === 'halfplane';
        const round = s.type === 'disc' || s.type === 'ellipse' || s.type === 'superellipse';
        if (round) {
          // A light spoke along the shape's x axis shows its rotation.
          const a = s.type === 'disc' ? s.radius : s.half_extents[0];
          const w = 0.12 * (s.type === 'disc' ? s.radius : Math.min(a, s.half_extents[1]));
          const spoke = new THREE.Mesh(new (Geometry('Plane'))(a, w),
                                       new THREE.MeshBasicMaterial({
                                         color: color.clone().lerp(new THREE.Color(0xffffff), 0.55)
                                       }));
          spoke.position.set(a / 2, 0, th / 2 + th * 0.02);
          const mesh = this.meshOf(geom, color, false, false);
          mesh.add(spoke);
          return mesh;
        }
      } else {
        switch (s.type) {
          case 'halfspace': {
            const L = ext.size * 3;
            geom = new (Geometry('Plane'))(L, L);
            geom.translate(centerInShape.x, centerInShape.y, 0);
            flat = true;
            break;
          }
          case 'box': geom = new (Geometry('Box'))(2 * he[0], 2 * he[1], 2 * he[2]); break;
          case 'sphere': geom = new (Geometry('Sphere'))(s.radius, 48, 24); smooth = true; break;
          case 'capsule': {
            const prof = [], n = 16, r = s.radius, h = s.half_length;
            for (let i = 0; i <= n; ++i) {
              const a = -Math.PI / 2 + (Math.PI / 2) * i / n;
              prof.push([r * Math.cos(a), -h + r * Math.sin(a)]);
            }
            for (let i = 0; i <= n; ++i) {
              const a = (Math.PI / 2) * i / n;
              prof.push([r * Math.cos(a), h + r * Math.sin(a)]);
            }
            geom = latheZ(prof, 48);
            smooth = true;
            break;
          }
          case 'cylinder':
            geom = new (Geometry('Cylinder'))(s.radius, s.radius, 2 * s.half_length, 48);
            geom.rotateX(Math.PI / 2);
            smooth = true;
            break;
          case 'lens': {
            // Spheres of radius R centred at z = +-(R - h); the upper cap belongs to the lower one.
            const R = s.radius, h = s.half_length, d = R - h, rim = Math.acos(d / R);
            const prof = [], n = 24;
            for (let i = 0; i <= n; ++i) {
              const a = rim * i / n;
              prof.push([R * Math.sin(a), d - R * Math.cos(a)]);
            }
            for (let i = n - 1; i >= 0; --i) {
              const a = rim * i / n;
              prof.push([R * Math.sin(a), -d + R * Math.cos(a)]);
            }
            geom = latheZ(prof, 48);
            smooth = true;
            break;
          }
          case 'ellipsoid': geom = superquadric(he[0], he[1], he[2], 2); smooth = true; break;
          case 'superquadric':
            geom = superquadric(he[0], he[1], he[2], s.exponent);
            smooth = true;
            break;
          case 'polyhedron': geom = polyhedron(s); break;
          default: throw new Error('unknown shape type ' + s.type);
        }
      }
      return this.meshOf(geom, color, smooth, flat, centerInShape, s);
    }

    // A mesh of `geom` in `color` (smooth: octant colours; flat: a finite plane with a grid),
    // with its sharp edges drawn.
    meshOf(geom, color, smooth, flat, centerInShape, s) {
      const vertexColors = smooth && octantColors(geom, color);
      const mat = new THREE.MeshPhongMaterial({
        color: vertexColors ? 0xffffff : color,
        // three.js r111 takes the constant VertexColors, later releases a boolean.
        vertexColors: vertexColors ? (THREE.VertexColors !== undefined ? THREE.VertexColors : true)
                                   : (THREE.NoColors !== undefined ? THREE.NoColors : false),
        side: flat ? THREE.DoubleSide : THREE.FrontSide, shininess: 25,
        polygonOffset: flat, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
      });
      const mesh = new THREE.Mesh(geom, mat);
      if (flat) {
        mesh.add(this.buildGrid(s, centerInShape));
      } else {
        const edges = new THREE.LineSegments(new THREE.EdgesGeometry(geom, 25),
                                             new THREE.LineBasicMaterial({ color: kEdgeColor }));
        mesh.add(edges);
      }
      return mesh;
    }

    // Grid lines on a half-space (its z = 0 plane) or over a half-plane's band.
    buildGrid(s, c) {
      const L = this.extent.size * 3;
      const step = Math.pow(10, Math.floor(Math.log10(L / 10)));
      const pts = [];
      const x0 = Math.ceil((c.x - L / 2) / step) * step, x1 = c.x + L / 2;
      const z = this.planar ? this.extent.size * 0.01 + 1e-9 : 0;
      if (this.planar) {
        for (let x = x0; x <= x1; x += step) pts.push(x, -L / 3, z, x, 0, z);
        for (let y = 0; y >= -L / 3; y -= step) pts.push(c.x - L / 2, y, z, c.x + L / 2, y, z);
      } else {
        const y0 = Math.ceil((c.y - L / 2) / step) * step, y1 = c.y + L / 2;
        for (let x = x0; x <= x1; x += step) pts.push(x, c.y - L / 2, 0, x, c.y + L / 2, 0);
        for (let y = y0; y <= y1; y += step) pts.push(c.x - L / 2, y, 0, c.x + L / 2, y, 0);
      }
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(pts, 3));
      return new THREE.LineSegments(g, new THREE.LineBasicMaterial({
        color: 0x7d848c, transparent: true, opacity: 0.5 }));
    }

    // Velocity field: an arrow per point, length proportional to the speed (the fastest: 0.9 grid spacing).
    buildField(f) {
      this.fieldGroup = new THREE.Group();
      let vmax = 0;
      for (const p of f.points) if (!p.failed && p.v[0] !== null) vmax = Math.max(vmax, v3(p.v).length());
      const spacing = f.spacing > 0 ? f.spacing : this.extent.size * 0.1;
      // Just off the plate: planar above its surface line and in front of the extruded shapes.
      const lift = this.planar ? v3(f.normal).multiplyScalar(spacing * 0.15)
                                     .add(new THREE.Vector3(0, 0, this.extent.size * 0.011))
                               : v3(f.normal).multiplyScalar(spacing * 0.05);
      for (const p of f.points) {
        const origin = v3(p.p).add(lift);
        if (p.failed) {
          const m = new THREE.Mesh(new (Geometry('Sphere'))(spacing * 0.12, 12, 8),
                                   new THREE.MeshBasicMaterial({ color: 0xd0021b }));
          m.position.copy(origin);
          this.fieldGroup.add(m);
          continue;
        }
        const v = v3(p.v), speed = v.length();
        const len = vmax > 0 ? 0.9 * spacing * speed / vmax : 0;
        if (len < 1e-6 * spacing) {
          const dot = new THREE.Mesh(new (Geometry('Sphere'))(spacing * 0.04, 8, 6),
                                     new THREE.MeshBasicMaterial({ color: 0x222222 }));
          dot.position.copy(origin);
          this.fieldGroup.add(dot);
          continue;
        }
        const color = p.left_plate ? new THREE.Color(0x888888)
                                   : new THREE.Color().setHSL(0.66 - 0.66 * speed / vmax, 0.85, 0.42);
        this.fieldGroup.add(new THREE.ArrowHelper(v.normalize(), origin, len, color.getHex(),
                                                  Math.min(0.3 * len, 0.25 * spacing),
                                                  Math.min(0.2 * len, 0.15 * spacing)));
      }
      this.fieldVmax = vmax;
      this.scene.add(this.fieldGroup);
    }

    setupCamera() {
      const ext = this.extent;
      this.camera = new THREE.PerspectiveCamera(35, 1, ext.size * 1e-3, ext.size * 100);
      this.camera.up.copy(this.up);
      const radius = ext.size / 2;
      const dist = radius / Math.sin((35 / 2) * Math.PI / 180) * 1.05;
      let dir;
      if (this.planar) {
        dir = new THREE.Vector3(0, 0, 1);
      } else {
        // From the front-right and somewhat above, in a frame built on "up".
        const u = this.up;
        let side = new THREE.Vector3(1, 0, 0);
        if (Math.abs(side.dot(u)) > 0.9) side = new THREE.Vector3(0, 1, 0);
        side.addScaledVector(u, -side.dot(u)).normalize();
        const front = new THREE.Vector3().crossVectors(u, side).negate();  // toward the viewer
        dir = front.multiplyScalar(0.85).addScaledVector(side, 0.35).addScaledVector(u, 0.4)
                  .normalize();
      }
      this.camera.position.copy(ext.center).addScaledVector(dir, dist);
      this.controls = new THREE.OrbitControls(this.camera, this.renderer.domElement);
      this.controls.target.copy(ext.center);
      this.controls.update();
      this.controls.addEventListener('change', () => { this.dirty = true; });
    }

    setupControls() {
      const tr = this.traj;
      const follow = $('follow');
      this.bodies.forEach((b, i) => {
        if (b.kind === 'static') return;
        const o = document.createElement('option');
        o.value = String(i);
        o.textContent = b.name;
        follow.appendChild(o);
      });
      follow.addEventListener('change', () => this.setFollow(follow.value === '' ? -1 : +follow.value));
      $('play').addEventListener('click', () => this.togglePlay());
      $('first').addEventListener('click', () => this.setTime(this.t0));
      $('last').addEventListener('click', () => this.setTime(this.t1));
      $('back').addEventListener('click', () => this.stepFrame(-1));
      $('fwd').addEventListener('click', () => this.stepFrame(1));
      $('speed').addEventListener('change', () => { this.speed = +$('speed').value; });
      $('slider').addEventListener('input', () => {
        this.playing = false;
        this.setTime(this.t0 + (this.t1 - this.t0) * $('slider').value / 1e6);
      });
      $('overlay').addEventListener('change', () => {
        $('plotbox').style.display = $('overlay').checked && this.hasPlot ? '' : 'none';
      });
      if (this.data.field) {
        $('showfield').addEventListener('change', () => {
          this.fieldGroup.visible = $('showfield').checked;
          this.dirty = true;
        });
      } else {
        $('fieldlabel').style.display = 'none';
      }
      $('link').addEventListener('click', () => {
        history.replaceState(null, '', '#t=' + this.time.toPrecision(8));
      });
      if (!tr) {
        for (const id of ['first', 'back', 'play', 'fwd', 'last', 'slider', 'speed'])
          $(id).disabled = true;
      }
      window.addEventListener('keydown', (e) => {
        if (e.target.tagName === 'SELECT' || e.target.tagName === 'INPUT' && e.target.type !== 'range'
            && e.target.type !== 'checkbox') return;
        if (e.key === ' ') { this.togglePlay(); e.preventDefault(); }
        else if (e.key === 'ArrowRight') { this.stepFrame(1); e.preventDefault(); }
        else if (e.key === 'ArrowLeft') { this.stepFrame(-1); e.preventDefault(); }
        else if (e.key === 'Home') this.setTime(this.t0);
        else if (e.key === 'End') this.setTime(this.t1);
      });
      window.addEventListener('hashchange', () => this.applyHash());
    }

    // #t=1.8[&follow=name][&field=0|1][&play]
    applyHash() {
      const params = new URLSearchParams(location.hash.replace(/^#/, ''));
      let t = this.t0;
      if (params.has('t')) {
        const v = parseFloat(params.get('t'));
        if (!isFinite(v)) throw new Error('bad time in the address: #t=' + params.get('t'));
        t = v;
      }
      if (params.has('follow')) {
        const i = this.bodies.findIndex((b) => b.name === params.get('follow'));
        if (i >= 0) { this.setFollow(i); $('follow').value = String(i); }
      }
      if (params.has('field') && this.fieldGroup) {
        $('showfield').checked = params.get('field') !== '0';
        this.fieldGroup.visible = $('showfield').checked;
      }
      this.playing = false;
      this.setTime(t);
      if (params.has('play') && this.traj) this.togglePlay();
    }

    setFollow(i) {
      this.follow = i;
      if (i >= 0) {
        const p = new THREE.Vector3(), q = new THREE.Quaternion();
        this.bodyPose(i, p, q);
        this.followLast = p;
      }
      this.dirty = true;
    }

    togglePlay() {
      if (!this.traj) return;
      if (!this.playing && this.time >= this.t1) this.setTime(this.t0);
      this.playing = !this.playing;
      this.lastWall = null;
      $('play').innerHTML = this.playing ? '&#10074;&#10074;' : '&#9654;';
    }

    stepFrame(d) {
      if (!this.traj) return;
      this.playing = false;
      $('play').innerHTML = '&#9654;';
      const { k, a } = this.locate(this.time);
      let j = d > 0 ? k + 1 : (a > 0 ? k : k - 1);
      j = Math.max(0, Math.min(this.traj.t.length - 1, j));
      this.setTime(this.traj.t[j]);
    }

    setTime(t) {
      this.time = Math.max(this.t0, Math.min(this.t1, t));
      this.dirty = true;
    }

    // Moves the bodies to the current time and refreshes the text and the slider.
    update() {
      const p = new THREE.Vector3(), q = new THREE.Quaternion();
      this.groups.forEach((g, i) => {
        this.bodyPose(i, p, q);
        g.position.copy(p);
        g.quaternion.copy(q);
      });
      if (this.follow >= 0) {
        this.bodyPose(this.follow, p, q);
        if (this.followLast) {
          const d = p.clone().sub(this.followLast);
          this.camera.position.add(d);
          this.controls.target.add(d);
          this.controls.update();
        }
        this.followLast = p.clone();
      }
      const tr = this.traj;
      const span = this.t1 - this.t0;
      $('slider').value = span > 0 ? Math.round(1e6 * (this.time - this.t0) / span) : 0;
      $('time').textContent = 't = ' + this.time.toFixed(4) + ' / ' + this.t1.toFixed(4) + ' s';
      this.updateInfo();
      this.drawPlot();
    }

    updateInfo() {
      const d = this.data, tr = this.traj, sc = this.sceneData;
      const esc = (s) => String(s).replace(/[&<>"]/g, (c) => '&#' + c.charCodeAt(0) + ';');
      let h = '<div class="name">' + esc(sc.name || '(unnamed scene)') + '</div>';
      h += '<div class="dim">' + (this.planar ? 'planar' : 'spatial') + ', ' + sc.bodies.length +
           ' bodies, dt = ' + sc.dt + ' s</div>';
      if (tr) {
        const { k } = this.locate(this.time);
        h += '<div>step ' + tr.step[k] + ' (frame ' + (k + 1) + ' / ' + tr.frames + ')</div>';
        if (tr.frames < tr.rows)
          h += '<div class="dim">' + tr.rows + ' rows shown as ' + tr.frames + ' frames</div>';
        const r = tr.report;
        if (r) {
          const res = r.residual[k];
          h += '<div>contacts ' + r.contacts[k] + ', iterations ' + r.iterations[k] + '</div>';
          h += '<div>residual ' + (res === null ? 'NaN' : res.toExponential(2)) + ', min gap ' +
               (r.min_gap[k] === null ? '-' : (r.min_gap[k] * 1e3).toPrecision(3) + ' mm') + '</div>';
          const st = r.status_names[r.status[k]];
          h += '<div' + (st === 'solved' || st === 'initial' ? '' : ' class="warn"') + '>status ' +
               esc(st) + '</div>';
          if (r.num_flagged > 0)
            h += '<div class="warn">' + r.num_flagged + ' steps not solved (red marks)</div>';
        }
        if (sc.duration > 0 && this.t1 < sc.duration - 0.5 * sc.dt)
          h += '<div class="dim">ends at ' + this.t1.toFixed(4) + ' s of the scene\'s ' +
               sc.duration + ' s</div>';
      } else {
        h += '<div class="dim">no trajectory: initial pose</div>';
      }
      if (d.field) {
        h += '<div>field: ' + d.field.points.length + ' points, max ' +
             (this.fieldVmax * 1e3).toPrecision(3) + ' mm/s (' + esc(d.field.part) + ' on ' +
             esc(d.field.plate) + ')</div>';
      }
      $('info').innerHTML = h;
    }

    // ---- report plot ---------------------------------------------------------------------

    setupPlot() {
      const r = this.traj && this.traj.report;
      this.hasPlot = !!r && this.traj.frames > 1;
      if (!this.hasPlot) {
        $('plotbox').style.display = 'none';
        $('overlay').parentElement.style.display = 'none';
        return;
      }
      const T = this.traj.t;
      const series = [
        { name: 'contacts', color: '#1f6fb4', values: r.contacts, log: false },
        { name: 'iterations', color: '#7b4bb0', values: r.iterations, log: false },
        { name: 'log10 residual', color: '#2e8b57', values: r.residual, log: true },
      ];
      for (const s of series) {
        const vals = s.values.map((v) => (v === null ? NaN
                                          : s.log ? Math.log10(Math.max(v, 1e-300)) : v));
        const fin = vals.filter((v) => isFinite(v) && (!s.log || v > -300));
        s.lo = s.log ? (fin.length ? Math.min(...fin) : 0) : 0;
        s.hi = fin.length ? Math.max(...fin) : 1;
        if (!(s.hi > s.lo)) s.hi = s.lo + 1;
        s.plotted = vals;
      }
      this.plotSeries = series;
      // A solver that returns exact solutions reports residual 0: nothing to plot on a log scale.
      const exact = series[2].plotted.every((v) => !isFinite(v) || v <= -300);
      $('legend').innerHTML = series.map((s) => '<span style="color:' + s.color + '">&#9632; ' +
                                         s.name + (s.log && exact ? ' (all 0)' : '') + '</span>')
                                  .join('') +
                              '<span style="color:#d0021b">| not solved</span>';
      const seek = (e) => {
        const c = $('plot'), rect = c.getBoundingClientRect();
        const x = (e.clientX - rect.left) / rect.width;
        this.playing = false;
        this.setTime(this.t0 + x * (this.t1 - this.t0));
      };
      $('plot').addEventListener('mousedown', (e) => { seek(e); this.plotDrag = true; });
      window.addEventListener('mousemove', (e) => { if (this.plotDrag) seek(e); });
      window.addEventListener('mouseup', () => { this.plotDrag = false; });
      this.T = T;
    }

    drawPlot() {
      if (!this.hasPlot || !$('overlay').checked) return;
      const c = $('plot'), ctx = c.getContext('2d'), W = c.width, H = c.height;
      const T = this.traj.t, span = this.t1 - this.t0 || 1;
      const X = (t) => (t - this.t0) / span * (W - 2) + 1;
      ctx.clearRect(0, 0, W, H);
      ctx.fillStyle = '#fafafa';
      ctx.fillRect(0, 0, W, H);
      for (const s of this.plotSeries) {
        ctx.strokeStyle = s.color;
        ctx.lineWidth = 1.2;
        ctx.beginPath();
        let pen = false;
        for (let k = 0; k < T.length; ++k) {
          const v = s.plotted[k];
          if (!isFinite(v) || k === 0) { pen = false; continue; }  // row 0 has no report
          const y = H - 4 - (v - s.lo) / (s.hi - s.lo) * (H - 12);
          if (pen) ctx.lineTo(X(T[k]), y); else ctx.moveTo(X(T[k]), y);
          pen = true;
        }
        ctx.stroke();
      }
      const r = this.traj.report;
      ctx.strokeStyle = '#d0021b';
      ctx.lineWidth = 1;
      ctx.beginPath();
      for (const f of r.flagged) { ctx.moveTo(X(f.t), 0); ctx.lineTo(X(f.t), 8); }
      ctx.stroke();
      ctx.strokeStyle = '#000';
      ctx.beginPath();
      ctx.moveTo(X(this.time), 0);
      ctx.lineTo(X(this.time), H);
      ctx.stroke();
      ctx.fillStyle = '#555';
      ctx.font = '10px sans-serif';
      ctx.fillText(this.t0.toPrecision(3) + ' s', 3, H - 3);
      const end = this.t1.toPrecision(3) + ' s';
      ctx.fillText(end, W - 3 - ctx.measureText(end).width, H - 3);
    }

    // ---- loop ----------------------------------------------------------------------------

    resize() {
      const w = window.innerWidth, h = window.innerHeight;
      this.renderer.setSize(w, h);
      this.camera.aspect = w / Math.max(h, 1);
      this.camera.updateProjectionMatrix();
      this.dirty = true;
    }

    render() {
      this.update();
      this.renderer.render(this.scene, this.camera);
      this.dirty = false;
      document.body.setAttribute('data-vinci-time', String(this.time));  // the time drawn
    }

    start() {
      this.applyHash();
      this.render();
      if (document.body.getAttribute('data-vinci-state') === 'loading') {
        document.body.setAttribute('data-vinci-state', 'ready');
        document.title = 'vinci view: ' + (this.sceneData.name || 'scene');
      }
      const loop = (now) => {
        if (this.playing) {
          if (this.lastWall !== null) this.setTime(this.time + (now - this.lastWall) / 1e3 * this.speed);
          this.lastWall = now;
          if (this.time >= this.t1) this.togglePlay();
          this.dirty = true;
        }
        if (this.dirty) this.render();
        requestAnimationFrame(loop);
      };
      requestAnimationFrame(loop);
    }
  }

  try {
    main();
  } catch (e) {
    window.vinciFail(e && e.stack ? e.stack : String(e));
  }
})();
