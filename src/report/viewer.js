(function () {
  'use strict';
  var data = JSON.parse(document.getElementById('viewer-data').textContent);
  var fi = 0, si = 0, prev = 0, zoom = data.zoom, ev = 0, showErr = false;
  var cv = document.getElementById('v-canvas'), ctx = cv.getContext('2d', { willReadFrequently: true });
  var label = document.getElementById('v-name');
  function srgbDec(v) { return v <= 0.04045 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4); }
  function srgbEnc(v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055; }
  // The ACES fit of Narkowicz the PNGs were tonemapped with, and its inverse.
  function aces(x) { return Math.min(1, Math.max(0, (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14))); }
  function acesInv(d) {
    if (d <= 0) return 0;
    var a = 2.43 * d - 2.51, b = 0.59 * d - 0.03, c = 0.14 * d;
    return (-b - Math.sqrt(b * b - 4 * a * c)) / (2 * a);
  }
  function lut() {
    var s = Math.pow(2, ev), t = new Uint8ClampedArray(256);
    for (var v = 0; v < 256; v++) t[v] = Math.round(255 * srgbEnc(aces(s * acesInv(srgbDec(v / 255)))));
    return t;
  }
  function draw() {
    var f = data.frames[fi], s = f.sources[si], err = showErr && !!s.flip;
    var img = document.getElementById(err ? s.flip : s.id);
    var w = img.naturalWidth, h = img.naturalHeight;
    cv.width = w; cv.height = h;
    ctx.drawImage(img, 0, 0);
    if (ev !== 0 && !err) {
      var d = ctx.getImageData(0, 0, w, h), p = d.data, t = lut();
      for (var i = 0; i < p.length; i += 4) { p[i] = t[p[i]]; p[i + 1] = t[p[i + 1]]; p[i + 2] = t[p[i + 2]]; }
      ctx.putImageData(d, 0, 0);
    }
    cv.style.width = (w * zoom) + 'px'; cv.style.height = (h * zoom) + 'px';
    cv.dataset.source = s.name;
    label.textContent = 'frame ' + f.frame + ': ' + s.name + (err ? ' (HDR-FLIP map)' : '') + ', ' + zoom + '\u00d7, EV ' + ev;
    document.getElementById('v-zoom').textContent = zoom + '\u00d7';
    document.getElementById('v-ev-val').textContent = ev;
    var bs = document.querySelectorAll('#v-sources button');
    for (var k = 0; k < bs.length; k++) bs[k].className = k === si ? 'on' : '';
  }
  function pick(i) {
    var n = data.frames[fi].sources.length;
    i = ((i % n) + n) % n;
    if (i !== si) { prev = si; si = i; }
    draw();
  }
  function setZoom(z) { zoom = Math.max(1, Math.min(64, z)); draw(); }
  var box = document.getElementById('v-sources');
  data.frames[0].sources.forEach(function (s, i) {
    var b = document.createElement('button');
    b.textContent = (i < 9 ? '(' + (i + 1) + ') ' : '') + s.name;
    b.addEventListener('click', function () { pick(i); });
    box.appendChild(b);
  });
  var sel = document.getElementById('v-frame');
  data.frames.forEach(function (f, i) {
    var o = document.createElement('option');
    o.value = i; o.textContent = 'frame ' + f.frame;
    sel.appendChild(o);
  });
  sel.addEventListener('change', function () { fi = +sel.value; draw(); });
  document.getElementById('v-zoom-in').addEventListener('click', function () { setZoom(zoom * 2); });
  document.getElementById('v-zoom-out').addEventListener('click', function () { setZoom(zoom / 2); });
  var evIn = document.getElementById('v-ev');
  evIn.addEventListener('input', function () { ev = +evIn.value; draw(); });
  var errIn = document.getElementById('v-err');
  errIn.addEventListener('change', function () { showErr = errIn.checked; draw(); });
  document.getElementById('v-wrap').addEventListener('wheel', function (e) {
    e.preventDefault();
    setZoom(e.deltaY < 0 ? zoom * 2 : zoom / 2);
  }, { passive: false });
  document.addEventListener('keydown', function (e) {
    var k = e.key;
    if (k >= '1' && k <= '9') pick(+k - 1);
    else if (k === 'ArrowRight') pick(si + 1);
    else if (k === 'ArrowLeft') pick(si - 1);
    else if (k === 'f') pick(prev);
    else if (k === '+' || k === '=') setZoom(zoom * 2);
    else if (k === '-') setZoom(zoom / 2);
    else if (k === 'e') { errIn.checked = !errIn.checked; showErr = errIn.checked; draw(); }
    else if (k === ']' || k === '[') { fi = (fi + (k === ']' ? 1 : data.frames.length - 1)) % data.frames.length; sel.value = fi; draw(); }
    else return;
    e.preventDefault();
  });
  function digest() {
    var p = ctx.getImageData(0, 0, cv.width, cv.height).data, h = 2166136261;
    for (var i = 0; i < p.length; i++) h = Math.imul(h ^ p[i], 16777619) >>> 0;
    return { source: cv.dataset.source, hash: h };
  }
  window.addEventListener('load', function () {
    draw();
    // `report.html#selftest`: a scripted interaction whose outcome the
    // tests read from the DOM (tests/report.rs).
    if (location.hash !== '#selftest') return;
    var r = { sources: data.frames[0].sources.map(function (s) { return s.name; }), first: digest() };
    document.dispatchEvent(new KeyboardEvent('keydown', { key: 'ArrowRight' }));
    r.key = digest();
    box.lastChild.click();
    r.click = digest();
    evIn.value = '2'; evIn.dispatchEvent(new Event('input'));
    r.exposure = digest();
    document.getElementById('v-selftest').textContent = JSON.stringify(r);
  });
})();
