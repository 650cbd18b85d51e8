// Builds each failing variant's animated view from its JSON data.
(function () {
  'use strict';
  var NS = 'http://www.w3.org/2000/svg';
  function make(parent, name, attrs) {
    var e = document.createElementNS(NS, name);
    for (var k in attrs) { e.setAttribute(k, attrs[k]); }
    parent.appendChild(e);
    return e;
  }
  // Scenario y is up; SVG y is down.
  function pts(list) {
    return list.map(function (p) { return p[0] + ',' + (-p[1]); }).join(' ');
  }
  function corners(s, a) {
    var c = Math.cos(s[2]), n = Math.sin(s[2]), l = a.length_m / 2, w = a.width_m / 2;
    return [[l, w], [l, -w], [-l, -w], [-l, w]].map(function (d) {
      return [s[0] + c * d[0] - n * d[1], s[1] + n * d[0] + c * d[1]];
    });
  }
  function setup(player) {
    var data = JSON.parse(player.querySelector('script.rollout').textContent);
    var svg = player.querySelector('svg.scene');
    var v = data.view, w = v[2] - v[0], h = v[3] - v[1], last = data.frames.length - 1;
    var follow = player.querySelector('input.follow');
    // The whole view, or a 16:9 window of at most 80 m around the ego (and the CBV when near).
    function frameView(f) {
      var fw = Math.min(w, 80), fh = Math.min(h, fw * 9 / 16), e = f[0];
      var c = data.agents.length > 1 && data.agents[1].role === 'cbv' ? f[1] : null;
      if (!follow.checked || !e || (fw >= w && fh >= h)) { return [v[0], -v[3], w, h]; }
      var x = e[0], y = e[1];
      if (c && Math.abs(c[0] - x) < fw * 0.6 && Math.abs(c[1] - y) < fh * 0.6) { x = (x + c[0]) / 2; y = (y + c[1]) / 2; }
      x = Math.max(v[0] + fw / 2, Math.min(v[2] - fw / 2, x));
      y = Math.max(v[1] + fh / 2, Math.min(v[3] - fh / 2, y));
      return [x - fw / 2, -(y + fh / 2), fw, fh];
    }
    svg.setAttribute('viewBox', [v[0], -v[3], w, h].join(' '));
    make(svg, 'rect', { x: v[0], y: -v[3], width: w, height: h, 'class': 'ground' });
    data.map.forEach(function (line) {
      make(svg, line.kind === 'drivable' ? 'polygon' : 'polyline', { points: pts(line.points), 'class': 'map ' + line.kind });
    });
    data.agents.forEach(function (a, i) {
      if (a.role === 'ego' || a.role === 'cbv') {
        var path = data.frames.map(function (f) { return f[i]; }).filter(Boolean);
        make(svg, 'polyline', { points: pts(path), 'class': 'path ' + a.role });
      }
    });
    // Others first, ego and CBV last: drawn on top.
    var order = data.agents.map(function (a, i) { return i; }).filter(function (i) {
      return data.agents[i].role !== 'ego' && data.agents[i].role !== 'cbv';
    }).concat(data.agents.map(function (a, i) { return i; }).filter(function (i) {
      return data.agents[i].role === 'ego' || data.agents[i].role === 'cbv';
    }));
    var boxes = [];
    order.forEach(function (i) {
      var a = data.agents[i];
      var g = make(svg, 'g', { 'class': 'agent ' + a.role });
      make(g, 'title', {}).textContent = a.id + ' (' + a.role + ')';
      var box = { g: g, poly: make(g, 'polygon', { 'class': 'box' }), head: make(g, 'line', { 'class': 'head' }) };
      if (a.role === 'ego' || a.role === 'cbv') { box.label = make(g, 'text', {}); box.label.textContent = a.role === 'ego' ? 'ego' : 'CBV'; }
      boxes[i] = box;
    });
    var slider = player.querySelector('input.step'), out = player.querySelector('output.time');
    var button = player.querySelector('button.play'), timer = null;
    slider.max = last;
    function show(k) {
      var f = data.frames[k];
      boxes.forEach(function (b, i) {
        var s = f[i];
        if (!s) { b.g.setAttribute('visibility', 'hidden'); return; }
        b.g.removeAttribute('visibility');
        var c = corners(s, data.agents[i]);
        b.poly.setAttribute('points', pts(c));
        b.head.setAttribute('x1', s[0]); b.head.setAttribute('y1', -s[1]);
        b.head.setAttribute('x2', (c[0][0] + c[1][0]) / 2); b.head.setAttribute('y2', -(c[0][1] + c[1][1]) / 2);
        if (b.label) { b.label.setAttribute('x', s[0] - 1.2); b.label.setAttribute('y', -s[1] - data.agents[i].width_m / 2 - 0.5); }
        var hit = data.collisions.some(function (x) { return x.frame <= k && x.agents.indexOf(i) >= 0; });
        b.g.classList.toggle('collided', hit);
      });
      svg.setAttribute('viewBox', frameView(f).join(' '));
      slider.value = k;
      out.textContent = 't = ' + (k * data.dt_s).toFixed(1) + ' s (step ' + k + ' of ' + last + ')';
    }
    function stop() {
      if (timer !== null) { clearInterval(timer); timer = null; }
      button.textContent = '\u25b6 play';
    }
    slider.addEventListener('input', function () { stop(); show(+slider.value); });
    follow.addEventListener('change', function () { show(+slider.value); });
    button.addEventListener('click', function () {
      if (timer !== null) { stop(); return; }
      var k = +slider.value >= last ? 0 : +slider.value;
      button.textContent = '\u275a\u275a pause';
      // Real time: one frame per simulation step.
      timer = setInterval(function () { show(k); k += 1; if (k > last) { stop(); } }, data.dt_s * 1000);
    });
    show(Math.min(data.initial_frame, last));
    player.setAttribute('data-ready', 'true');
    player.setAttribute('data-frames', String(data.frames.length));
  }
  Array.prototype.forEach.call(document.querySelectorAll('.player'), setup);
})();
