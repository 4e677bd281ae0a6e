// has: a small WebGL viewer for the 3D scene of a report.html (no library, no network).
// Data: the JSON of the script element id="has-scene": {"min":[x,y,z],"size":[x,y,z],
//   "layers":[{"name","colour":[r,g,b],"kind":"points"|"mesh","positions":base64 u16 LE xyz
//   quantised over min..min+size,"indices":base64 u32 LE (mesh),"note","point_px"}]}.
// Drag: orbit about the scene's centre (z up); wheel: zoom; the checkboxes show and hide layers.
// The page's <body> gets data-rendered="N" (layers drawn) or data-error="..." (for tests).
(function () {
  "use strict";
  window.addEventListener("error", function (e) {
    document.body.dataset.error = String(e.message || e);
  });
  var canvas = document.getElementById("has-view");
  var scene = JSON.parse(document.getElementById("has-scene").textContent);
  var gl = canvas.getContext("webgl", { preserveDrawingBuffer: true, antialias: true });
  if (!gl) {
    document.getElementById("has-view-note").textContent =
      "This browser gives no WebGL context: the 3D view is off (the plots below still show the run).";
    document.body.dataset.rendered = "0";
    return;
  }
  function bytes(b64) {
    var bin = atob(b64), u = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) u[i] = bin.charCodeAt(i);
    return u.buffer;
  }
  var min = scene.min, size = scene.size;
  function positions(b64) {
    var q = new Uint16Array(bytes(b64)), p = new Float32Array(q.length);
    for (var i = 0; i < q.length; i++) p[i] = min[i % 3] + (q[i] / 65535) * size[i % 3];
    return p;
  }
  // Meshes are drawn unindexed with flat face normals: each face's three corners.
  function faces(p, idx) {
    var n = idx.length, v = new Float32Array(n * 3), nr = new Float32Array(n * 3);
    for (var f = 0; f < n; f += 3) {
      var a = idx[f] * 3, b = idx[f + 1] * 3, c = idx[f + 2] * 3;
      var ux = p[b] - p[a], uy = p[b + 1] - p[a + 1], uz = p[b + 2] - p[a + 2];
      var vx = p[c] - p[a], vy = p[c + 1] - p[a + 1], vz = p[c + 2] - p[a + 2];
      var nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      var l = Math.sqrt(nx * nx + ny * ny + nz * nz) || 1;
      for (var k = 0; k < 3; k++) {
        var s = idx[f + k] * 3, o = (f + k) * 3;
        v[o] = p[s]; v[o + 1] = p[s + 1]; v[o + 2] = p[s + 2];
        nr[o] = nx / l; nr[o + 1] = ny / l; nr[o + 2] = nz / l;
      }
    }
    return { v: v, n: nr };
  }
  function shader(type, src) {
    var s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  }
  var prog = gl.createProgram();
  gl.attachShader(prog, shader(gl.VERTEX_SHADER,
    "attribute vec3 p; attribute vec3 n; uniform mat4 mvp; uniform float ps; varying float sh;" +
    "void main(){ gl_Position = mvp * vec4(p, 1.0); gl_PointSize = ps;" +
    " sh = 0.35 + 0.65 * abs(dot(n, normalize(vec3(0.35, 0.5, 0.8)))); }"));
  gl.attachShader(prog, shader(gl.FRAGMENT_SHADER,
    "precision mediump float; uniform vec3 col; uniform float lit; varying float sh;" +
    "void main(){ gl_FragColor = vec4(col * mix(1.0, sh, lit), 1.0); }"));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  gl.useProgram(prog);
  var loc = {
    p: gl.getAttribLocation(prog, "p"), n: gl.getAttribLocation(prog, "n"),
    mvp: gl.getUniformLocation(prog, "mvp"), ps: gl.getUniformLocation(prog, "ps"),
    col: gl.getUniformLocation(prog, "col"), lit: gl.getUniformLocation(prog, "lit")
  };
  var layers = scene.layers.map(function (L) {
    var p = positions(L.positions), buf = gl.createBuffer(), out = { L: L, on: true };
    if (L.kind === "mesh") {
      var m = faces(p, new Uint32Array(bytes(L.indices)));
      gl.bindBuffer(gl.ARRAY_BUFFER, buf);
      gl.bufferData(gl.ARRAY_BUFFER, m.v, gl.STATIC_DRAW);
      out.nbuf = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, out.nbuf);
      gl.bufferData(gl.ARRAY_BUFFER, m.n, gl.STATIC_DRAW);
      out.count = m.v.length / 3;
    } else {
      gl.bindBuffer(gl.ARRAY_BUFFER, buf);
      gl.bufferData(gl.ARRAY_BUFFER, p, gl.STATIC_DRAW);
      out.count = p.length / 3;
    }
    out.buf = buf;
    return out;
  });
  var panel = document.getElementById("has-layers");
  layers.forEach(function (l) {
    var label = document.createElement("label"), box = document.createElement("input");
    box.type = "checkbox";
    box.checked = true;
    box.addEventListener("change", function () { l.on = box.checked; draw(); });
    var c = l.L.colour, swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = "rgb(" + c[0] + "," + c[1] + "," + c[2] + ")";
    label.appendChild(box);
    label.appendChild(swatch);
    label.appendChild(document.createTextNode(" " + l.L.name + (l.L.note ? " (" + l.L.note + ")" : "")));
    panel.appendChild(label);
  });
  var centre = [min[0] + size[0] / 2, min[1] + size[1] / 2, min[2] + size[2] / 2];
  var radius = Math.max(1e-3, 0.5 * Math.sqrt(size[0] * size[0] + size[1] * size[1] + size[2] * size[2]));
  var az = -0.9, el = 0.55, dist = 2.1 * radius;
  function mul(a, b) {
    var r = new Float32Array(16);
    for (var i = 0; i < 4; i++)
      for (var j = 0; j < 4; j++) {
        var s = 0;
        for (var k = 0; k < 4; k++) s += a[k * 4 + j] * b[i * 4 + k];
        r[i * 4 + j] = s;
      }
    return r;
  }
  function matrix() {
    var eye = [centre[0] + dist * Math.cos(el) * Math.cos(az), centre[1] + dist * Math.cos(el) * Math.sin(az),
      centre[2] + dist * Math.sin(el)];
    var f = [centre[0] - eye[0], centre[1] - eye[1], centre[2] - eye[2]];
    var fl = Math.hypot(f[0], f[1], f[2]); f = [f[0] / fl, f[1] / fl, f[2] / fl];
    var s = [f[1], -f[0], 0], sl = Math.hypot(s[0], s[1]) || 1; s = [s[0] / sl, s[1] / sl, 0];
    var u = [s[1] * f[2] - s[2] * f[1], s[2] * f[0] - s[0] * f[2], s[0] * f[1] - s[1] * f[0]];
    var view = new Float32Array([s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
      -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]), -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]),
      f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2], 1]);
    var near = Math.max(dist - 2 * radius, dist / 100), far = dist + 2 * radius;
    var t = 1 / Math.tan(0.4), a = canvas.width / canvas.height;
    var proj = new Float32Array([t / a, 0, 0, 0, 0, t, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0,
      2 * far * near / (near - far), 0]);
    return mul(proj, view);
  }
  function draw() {
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.uniformMatrix4fv(loc.mvp, false, matrix());
    var drawn = 0;
    layers.forEach(function (l) {
      if (!l.on || l.count === 0) return;
      var c = l.L.colour;
      gl.uniform3f(loc.col, c[0] / 255, c[1] / 255, c[2] / 255);
      gl.bindBuffer(gl.ARRAY_BUFFER, l.buf);
      gl.enableVertexAttribArray(loc.p);
      gl.vertexAttribPointer(loc.p, 3, gl.FLOAT, false, 0, 0);
      if (l.nbuf) {
        gl.bindBuffer(gl.ARRAY_BUFFER, l.nbuf);
        gl.enableVertexAttribArray(loc.n);
        gl.vertexAttribPointer(loc.n, 3, gl.FLOAT, false, 0, 0);
        gl.uniform1f(loc.lit, 1);
        gl.drawArrays(gl.TRIANGLES, 0, l.count);
      } else {
        gl.disableVertexAttribArray(loc.n);
        gl.vertexAttrib3f(loc.n, 0, 0, 1);
        gl.uniform1f(loc.lit, 0);
        gl.uniform1f(loc.ps, l.L.point_px || 2);
        gl.drawArrays(gl.POINTS, 0, l.count);
      }
      drawn++;
    });
    document.body.dataset.rendered = String(drawn);
  }
  var drag = null;
  canvas.addEventListener("mousedown", function (e) { drag = [e.clientX, e.clientY]; });
  window.addEventListener("mouseup", function () { drag = null; });
  window.addEventListener("mousemove", function (e) {
    if (!drag) return;
    az -= (e.clientX - drag[0]) * 0.01;
    el = Math.max(-1.5, Math.min(1.5, el + (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
    draw();
  });
  canvas.addEventListener("wheel", function (e) {
    e.preventDefault();
    dist = Math.max(radius * 0.2, Math.min(radius * 10, dist * Math.exp(e.deltaY * 0.001)));
    draw();
  }, { passive: false });
  draw();
})();
