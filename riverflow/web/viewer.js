// riverflow's tile viewer: the water of a riverflow flow-tile pyramid (riverflow bake --tiles)
// on a Leaflet map, animated by particles that sample the tiles' velocity.
// Tile encoding (tiles.json "riverflow"): v = (rg * 2 - 1) * max_speed_mps, x east, y north
// (up the tile), B = 255 on water; A = 255.
(function () {
  "use strict";
  var cfg = JSON.parse(document.getElementById("rf-config").textContent);
  var tj = cfg.tilejson, rf = tj.riverflow, maxSpeed = rf.max_speed_mps;
  var minZ = tj.minzoom, maxZ = tj.maxzoom, TILE = rf.tile_px || 256;
  var url = tj.tiles[0];
  var b = tj.bounds;
  var map = L.map("map", {minZoom: Math.max(0, minZ - 2), maxZoom: maxZ + 3, fadeAnimation: false});
  map.fitBounds([[b[1], b[0]], [b[3], b[2]]]);
  if (cfg.basemap) {
    L.tileLayer(cfg.basemap, {maxZoom: maxZ + 3, attribution: cfg.attribution || ""}).addTo(map);
  }
  map.attributionControl.addAttribution("flow: riverflow");

  // --- the tiles' pixels, fetched once each (null: no water there) -------------------------
  var cache = {};
  function tileData(z, x, y) {
    var key = z + "/" + x + "/" + y;
    var hit = cache[key];
    if (hit !== undefined) { return hit; }
    var entry = {ready: false, data: null, waiters: []};
    cache[key] = entry;
    var n = 1 << z;
    if (x < 0 || y < 0 || x >= n || y >= n) { entry.ready = true; return entry; }
    var img = new Image();
    img.onload = function () {
      var c = document.createElement("canvas");
      c.width = c.height = TILE;
      var g = c.getContext("2d", {willReadFrequently: true});
      g.drawImage(img, 0, 0);
      var d = g.getImageData(0, 0, TILE, TILE).data;
      var any = false;
      for (var i = 2; i < d.length; i += 4) { if (d[i] > 127) { any = true; break; } }
      entry.data = any ? d : null;
      entry.ready = true;
      entry.waiters.forEach(function (f) { f(entry); });
    };
    img.onerror = function () { entry.ready = true; entry.waiters.forEach(function (f) { f(entry); }); };
    img.src = url.replace("{z}", z).replace("{x}", x).replace("{y}", y);
    return entry;
  }

  // --- the water, drawn from the tiles (blue where B says water) ------------------------
  var Water = L.GridLayer.extend({
    createTile: function (coords, done) {
      var tile = document.createElement("canvas");
      tile.width = tile.height = TILE;
      var z = Math.min(coords.z, maxZ), k = 1 << (coords.z - z);
      if (coords.z < minZ) { setTimeout(function () { done(null, tile); }, 0); return tile; }
      var tx = Math.floor(coords.x / k), ty = Math.floor(coords.y / k);
      var sx = (coords.x - tx * k) * TILE / k, sy = (coords.y - ty * k) * TILE / k;
      var draw = function (entry) {
        if (entry.data) {
          var g = tile.getContext("2d"), out = g.createImageData(TILE, TILE), o = out.data;
          for (var j = 0; j < TILE; j++) {
            for (var i = 0; i < TILE; i++) {
              var p = ((Math.floor(sy + j / k)) * TILE + Math.floor(sx + i / k)) * 4;
              if (entry.data[p + 2] > 127) {
                var q = (j * TILE + i) * 4;
                o[q] = 38; o[q + 1] = 104; o[q + 2] = 168; o[q + 3] = 255;
              }
            }
          }
          g.putImageData(out, 0, 0);
        }
        done(null, tile);
      };
      var entry = tileData(z, tx, ty);
      if (entry.ready) { setTimeout(function () { draw(entry); }, 0); } else { entry.waiters.push(draw); }
      return tile;
    }
  });
  new Water({tileSize: TILE, maxZoom: maxZ + 3}).addTo(map);

  // --- flow particles on a canvas over the map -------------------------------------------
  var canvas = document.createElement("canvas");
  canvas.className = "rf-particles";
  map.getContainer().appendChild(canvas);
  var ctx = canvas.getContext("2d");
  var N = cfg.particles || 1500, LIFE = 90;
  var px = new Float32Array(N), py = new Float32Array(N), age = new Int32Array(N);
  var alive = new Uint8Array(N);
  function resize() {
    var s = map.getSize();
    canvas.width = s.x; canvas.height = s.y;
    for (var i = 0; i < N; i++) { alive[i] = 0; }
  }
  map.on("resize moveend zoomend", resize);
  map.on("movestart zoomstart", function () { ctx.clearRect(0, 0, canvas.width, canvas.height); });
  resize();

  // the velocity (east, north) [m/s] at a container point, or null on land / not loaded
  var view = {ox: 0, oy: 0, scale: 1, z: minZ};
  function sample(x, y) {
    var gx = (view.ox + x) * view.scale, gy = (view.oy + y) * view.scale;
    var tx = Math.floor(gx / TILE), ty = Math.floor(gy / TILE);
    var entry = tileData(view.z, tx, ty);
    if (!entry.ready || !entry.data) { return null; }
    var p = ((Math.floor(gy) - ty * TILE) * TILE + (Math.floor(gx) - tx * TILE)) * 4;
    var d = entry.data;
    if (d[p + 2] <= 127) { return null; }
    return [(d[p] / 255 * 2 - 1) * maxSpeed, (d[p + 1] / 255 * 2 - 1) * maxSpeed];
  }

  var last = performance.now();
  function frame(now) {
    var dt = Math.min((now - last) / 1000, 0.1);
    last = now;
    var zoom = map.getZoom();
    view.z = Math.max(minZ, Math.min(maxZ, Math.round(zoom)));
    view.scale = Math.pow(2, view.z - zoom);
    var o = map.containerPointToLayerPoint([0, 0]).add(map.getPixelOrigin());
    view.ox = o.x; view.oy = o.y;
    // max_speed_mps crosses 60 screen pixels a second at any zoom (a picture, not physics)
    var gain = 60 / maxSpeed;
    ctx.globalCompositeOperation = "destination-out";
    ctx.fillStyle = "rgba(0, 0, 0, 0.12)";
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    ctx.globalCompositeOperation = "source-over";
    ctx.strokeStyle = "rgba(235, 246, 255, 0.75)";
    ctx.lineWidth = 1.2;
    ctx.beginPath();
    for (var i = 0; i < N; i++) {
      if (!alive[i] || age[i] > LIFE) {
        alive[i] = 0;
        for (var t = 0; t < 8 && !alive[i]; t++) {
          var x = Math.random() * canvas.width, y = Math.random() * canvas.height;
          if (sample(x, y)) { px[i] = x; py[i] = y; age[i] = Math.floor(Math.random() * LIFE); alive[i] = 1; }
        }
        continue;
      }
      var v = sample(px[i], py[i]);
      if (!v) { alive[i] = 0; continue; }
      var nx = px[i] + v[0] * gain * dt, ny = py[i] - v[1] * gain * dt;
      if (!sample(nx, ny)) { alive[i] = 0; continue; }
      ctx.moveTo(px[i], py[i]);
      ctx.lineTo(nx, ny);
      px[i] = nx; py[i] = ny; age[i]++;
    }
    ctx.stroke();
    requestAnimationFrame(frame);
  }
  requestAnimationFrame(frame);
  window.riverflowViewer = {map: map, sample: sample};
})();
