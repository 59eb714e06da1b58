// The wolfpack viewer: plays episodes packed by wolfpack/viewer/encode.py, from the data
// inlined in this page (no server, no network). One "item" of the list is one episode, or the
// same episode seed played by several policies (one pane each, scrubbed together).
// window.wolfpack is the read-only script interface (docs/guide.md).
(function () {
  "use strict";

  const DATA = JSON.parse(document.getElementById("wolfpack-data").textContent);
  const C = DATA.colours;
  const SPEEDS = [0.25, 0.5, 1, 2, 4, 8];
  const TRAIL = 40; // steps of trail, as the videos draw them
  const MIN_BODY_PX = 9; // bodies are drawn at true size but at least this long
  const MARGIN = 0.04; // of the arena, around it when the view fits it

  // --- decoding (encode.py's module docstring: zigzag LEB128 varints of row differences) ---

  function bytesOf(text) {
    const bin = atob(text);
    const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }

  // rows x width values, series by series in the stream; returned row-major, on the grid (as
  // integers over the grid's inverse, so that 3413 mm reads 3.413, not 3.4130000000000003).
  function series(text, rows, width, grid) {
    const bytes = bytesOf(text);
    const per = grid.map(function (g) { return Math.round(1 / g); });
    const out = new Float64Array(rows * width);
    let p = 0;
    for (let s = 0; s < width; s++) {
      let acc = 0;
      for (let t = 0; t < rows; t++) {
        let v = 0, mul = 1, b;
        do {
          if (p >= bytes.length) throw new Error("truncated episode data");
          b = bytes[p++];
          v += (b & 127) * mul;
          mul *= 128;
        } while (b & 128);
        acc += v % 2 ? -(v + 1) / 2 : v / 2;
        out[t * width + s] = acc / per[s % per.length];
      }
    }
    if (p !== bytes.length) throw new Error("episode data longer than its shape");
    return out;
  }

  // The law modes: agent by agent, (code, run length) pairs of the same varints; returned
  // row-major (rows x width codes).
  function runs(text, rows, width) {
    const bytes = bytesOf(text), out = new Uint8Array(rows * width);
    let p = 0;
    function next() {
      let v = 0, mul = 1, b;
      do {
        if (p >= bytes.length) throw new Error("truncated mode data");
        b = bytes[p++];
        v += (b & 127) * mul;
        mul *= 128;
      } while (b & 128);
      return v % 2 ? -(v + 1) / 2 : v / 2;
    }
    for (let s = 0; s < width; s++) {
      for (let t = 0; t < rows;) {
        const code = next(), length = next();
        if (!(length >= 1 && t + length <= rows)) throw new Error("mode data longer than its episode");
        for (const end = t + length; t < end; t++) out[t * width + s] = code;
      }
    }
    if (p !== bytes.length) throw new Error("mode data longer than its shape");
    return out;
  }

  const decoded = new Map();
  function episode(index) {
    if (decoded.has(index)) return decoded.get(index);
    const e = DATA.episodes[index];
    const rows = e.steps + 1, A = e.wolves + e.targets, K = e.obstacle_kind.length;
    const g = DATA.grid;
    const ep = {
      meta: e, rows: rows, A: A, N: e.wolves, M: e.targets, K: K,
      agents: series(e.agents, rows, A * 5, g.agent),
      poses: K ? series(e.poses, rows, K * 3, g.pose) : new Float64Array(0),
      energy: series(e.energy, rows, A, [g.energy]),
      links: bytesOf(e.interaction),
      modes: e.modes ? runs(e.modes, rows, A) : null, // null: the file recorded none
    };
    decoded.set(index, ep);
    return ep;
  }

  function agentAt(ep, t, a) {
    const o = (t * ep.A + a) * 5, s = ep.agents;
    return [s[o], s[o + 1], s[o + 2], s[o + 3], s[o + 4]];
  }
  // Whether observer i sensed or used agent j at step t (row t-1 of the interaction matrix).
  function linked(ep, t, i, j) {
    if (t < 1) return false;
    const bit = ((t - 1) * ep.A + i) * ep.A + j;
    return ((ep.links[bit >> 3] >> (7 - (bit & 7))) & 1) === 1;
  }
  // The name of the mode agent a's law was in at the step that led to state t ("none" at t = 0
  // and where no law drove it), or null where the episode records no modes.
  function modeName(ep, t, a) {
    return ep.modes ? DATA.mode_names[ep.modes[t * ep.A + a]] || "none" : null;
  }
  function captured(ep, j, t) {
    const end = ep.meta.target_capture_step[j];
    return end >= 0 && end <= t;
  }
  // --- the lidar, cast from the state as the core casts it (observe/mod.rs) -------------------

  function cross2(ax, ay, bx, by) { return ax * by - ay * bx; }
  function rayWalls(ox, oy, dx, dy, b) {
    const tx = dx > 0 ? (b[2] - ox) / dx : dx < 0 ? (b[0] - ox) / dx : Infinity;
    const ty = dy > 0 ? (b[3] - oy) / dy : dy < 0 ? (b[1] - oy) / dy : Infinity;
    return Math.max(0, Math.min(tx, ty));
  }
  function rayCircle(ox, oy, dx, dy, cx, cy, r, max) {
    const tx = cx - ox, ty = cy - oy, dist2 = tx * tx + ty * ty;
    if (dist2 <= r * r) return 0;
    const along = tx * dx + ty * dy;
    if (along < 0) return null;
    const miss2 = dist2 - along * along;
    if (miss2 > r * r) return null;
    const t = along - Math.sqrt(r * r - miss2);
    return t <= max ? Math.max(0, t) : null;
  }
  function insidePolygon(v, x, y) {
    let inside = false;
    for (let i = 0, j = v.length - 1; i < v.length; j = i++) {
      if ((v[i][1] > y) !== (v[j][1] > y) && x < (v[j][0] - v[i][0]) * (y - v[i][1]) / (v[j][1] - v[i][1]) + v[i][0]) inside = !inside;
    }
    return inside;
  }
  function rayPolygon(ox, oy, dx, dy, v, max) {
    if (insidePolygon(v, ox, oy)) return 0;
    let best = max, hit = false;
    for (let i = 0; i < v.length; i++) {
      const a = v[(i + v.length - 1) % v.length], b = v[i];
      const ex = b[0] - a[0], ey = b[1] - a[1], denom = cross2(dx, dy, ex, ey);
      if (denom === 0) continue;
      const ax = a[0] - ox, ay = a[1] - oy;
      const t = cross2(ax, ay, ex, ey) / denom, u = cross2(ax, ay, dx, dy) / denom;
      if (t >= 0 && u >= 0 && u <= 1 && t <= best) { best = t; hit = true; }
    }
    return hit ? best : null;
  }
  function worldVertices(ep, k, t) {
    const o = (t * ep.K + k) * 3, x = ep.poses[o], y = ep.poses[o + 1], ang = ep.poses[o + 2];
    const cs = Math.cos(ang), sn = Math.sin(ang);
    return ep.meta.obstacle_local[k].map(function (v) { return [x + cs * v[0] - sn * v[1], y + sn * v[0] + cs * v[1]]; });
  }
  // Distances (m) of agent a's lidar rays at step t; [] when the scenario has no lidar.
  function lidar(ep, t, a) {
    const rays = ep.meta.lidar ? ep.meta.lidar[0] : 0, range = rays ? ep.meta.lidar[1] : 0;
    const s = agentAt(ep, t, a), out = [];
    for (let k = 0; k < rays; k++) {
      const ang = s[2] + 2 * Math.PI * k / rays, dx = Math.cos(ang), dy = Math.sin(ang);
      let best = Math.min(rayWalls(s[0], s[1], dx, dy, ep.meta.border), range);
      for (let j = 0; j < ep.K; j++) {
        const o = (t * ep.K + j) * 3;
        const hit = ep.meta.obstacle_kind[j].endsWith("circle")
          ? rayCircle(s[0], s[1], dx, dy, ep.poses[o], ep.poses[o + 1], ep.meta.obstacle_radius[j], best)
          : rayPolygon(s[0], s[1], dx, dy, worldVertices(ep, j, t), best);
        if (hit !== null) best = Math.min(best, hit);
      }
      out.push(best);
    }
    return out;
  }

  // --- hunting points, placed from the state as the capture rule hunting_points and the bvc
  // law place them (geometry/ring.rs): each wolf hunts its nearest target still hunted (ties:
  // the lowest index); the n wolves of a target share n points evenly spaced on the ring of
  // radius bvc.radius around it, the first at angle 0, assigned by least total distance.
  // (bvc aims at the pack's last sighting of the target, the same point while one senses it.)

  function leastTotal(cost) { // exact minimum-cost assignment over subsets; cost[i][k]
    const n = cost.length, size = 1 << n, best = new Float64Array(size).fill(Infinity), from = new Int32Array(size);
    best[0] = 0;
    for (let mask = 0; mask < size; mask++) {
      if (best[mask] === Infinity) continue;
      let i = 0;
      for (let m = mask; m; m &= m - 1) i++; // wolf i takes the next point
      if (i >= n) continue;
      for (let k = 0; k < n; k++) {
        if (mask & (1 << k)) continue;
        const next = mask | (1 << k), c = best[mask] + cost[i][k];
        if (c < best[next]) { best[next] = c; from[next] = k; }
      }
    }
    const out = new Array(n);
    let mask = size - 1;
    for (let i = n - 1; i >= 0; i--) { const k = from[mask]; out[i] = k; mask &= ~(1 << k); }
    return out;
  }

  // [[x, y, wolf], ...]: each wolf's hunting point at step t (none for a wolf with no target).
  function hunting(ep, t) {
    const r = ep.meta.hunting_radius;
    if (!r) return [];
    const hunts = [];
    for (let i = 0; i < ep.N; i++) {
      const w = agentAt(ep, t, i);
      let best = -1, bestD = Infinity;
      for (let j = 0; j < ep.M; j++) {
        // a target's points stay at the step of its capture: they are what the capture met
        const end = ep.meta.target_capture_step[j];
        if (end >= 0 && end < t) continue;
        const s = agentAt(ep, t, ep.N + j), d = Math.hypot(s[0] - w[0], s[1] - w[1]);
        if (d < bestD) { best = j; bestD = d; }
      }
      hunts.push(best);
    }
    const out = [];
    for (let j = 0; j < ep.M; j++) {
      const wolves = [];
      hunts.forEach(function (h, i) { if (h === j) wolves.push(i); });
      if (!wolves.length || wolves.length > 16) continue;
      const s = agentAt(ep, t, ep.N + j), n = wolves.length, points = [];
      for (let k = 0; k < n; k++) points.push([s[0] + r * Math.cos(2 * Math.PI * k / n), s[1] + r * Math.sin(2 * Math.PI * k / n)]);
      // whole micrometres, as the core compares them
      const cost = wolves.map(function (i) { const w = agentAt(ep, t, i); return points.map(function (q) { return Math.round(Math.hypot(w[0] - q[0], w[1] - q[1]) / 1e-6); }); });
      leastTotal(cost).forEach(function (k, a) { out.push([points[k][0], points[k][1], wolves[a]]); });
    }
    return out.sort(function (a, b) { return a[2] - b[2]; });
  }

  function rgb(c) { return "rgb(" + c[0] + "," + c[1] + "," + c[2] + ")"; }
  function rgba(c, a) { return "rgba(" + c[0] + "," + c[1] + "," + c[2] + "," + a + ")"; }
  function wolfColour(i) { return C.wolves[i % C.wolves.length]; }
  function agentName(ep, a) { return a < ep.N ? "wolf " + a : (ep.M > 1 ? "target " + (a - ep.N) : "target"); }

  // --- what is shown ---------------------------------------------------------------------

  const view = {
    item: 0, step: 0, playing: false, speed: 1,
    zoom: 1, cx: null, cy: null, // the world point at the panes' centre (null: the arena's)
    trails: true, sensing: false, links: false, lidar: true, hunting: true,
    selected: null, // {pane, agent}
  };
  const panes = []; // {div, canvas, caption, index (episode), transform}

  function item() { return DATA.items[view.item]; }
  function paneEpisode(p) { return episode(item().episodes[p]); }
  function lastStep() {
    let last = 0;
    for (let p = 0; p < item().episodes.length; p++) last = Math.max(last, paneEpisode(p).rows - 1);
    return last;
  }

  // --- drawing ---------------------------------------------------------------------------

  function transformFor(canvas, ep) {
    const b = ep.meta.border;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    const bw = b[2] - b[0], bh = b[3] - b[1];
    const fit = Math.min(w / (bw * (1 + 2 * MARGIN)), h / (bh * (1 + 2 * MARGIN)));
    const s = fit * view.zoom;
    const cx = view.cx === null ? (b[0] + b[2]) / 2 : view.cx;
    const cy = view.cy === null ? (b[1] + b[3]) / 2 : view.cy;
    return { s: s, ox: w / 2 - cx * s, oy: h / 2 + cy * s, w: w, h: h };
  }
  function toPx(tr, x, y) { return [tr.ox + x * tr.s, tr.oy - y * tr.s]; }
  function toWorld(tr, px, py) { return [(px - tr.ox) / tr.s, (tr.oy - py) / tr.s]; }

  function obstaclePath(ctx, tr, ep, k, t) {
    const o = (t * ep.K + k) * 3;
    const x = ep.poses[o], y = ep.poses[o + 1], ang = ep.poses[o + 2];
    ctx.beginPath();
    if (ep.meta.obstacle_kind[k].endsWith("circle")) {
      const c = toPx(tr, x, y);
      ctx.arc(c[0], c[1], ep.meta.obstacle_radius[k] * tr.s, 0, 2 * Math.PI);
    } else {
      const cs = Math.cos(ang), sn = Math.sin(ang);
      ep.meta.obstacle_local[k].forEach(function (v, i) {
        const p = toPx(tr, x + cs * v[0] - sn * v[1], y + sn * v[0] + cs * v[1]);
        if (i === 0) ctx.moveTo(p[0], p[1]); else ctx.lineTo(p[0], p[1]);
      });
      ctx.closePath();
    }
  }

  // The body: an isosceles triangle, pose point at the base's midpoint, tip along the heading.
  function bodyPath(ctx, tr, ep, x, y, th) {
    const scale = Math.max(1, MIN_BODY_PX / (Math.max(ep.meta.body[0], ep.meta.body[1]) * tr.s));
    const hgt = ep.meta.body[0] * scale, half = ep.meta.body[1] * scale / 2;
    const c = Math.cos(th), s = Math.sin(th);
    const tip = toPx(tr, x + hgt * c, y + hgt * s);
    const l = toPx(tr, x - half * s, y + half * c);
    const r = toPx(tr, x + half * s, y - half * c);
    ctx.beginPath();
    ctx.moveTo(tip[0], tip[1]); ctx.lineTo(l[0], l[1]); ctx.lineTo(r[0], r[1]);
    ctx.closePath();
  }

  function cross(ctx, px, py, size) {
    ctx.save();
    ctx.lineCap = "round";
    for (const [colour, width] of [["#fff", 5], ["#000", 2.5]]) {
      ctx.strokeStyle = colour; ctx.lineWidth = width;
      ctx.beginPath();
      ctx.moveTo(px - size, py - size); ctx.lineTo(px + size, py + size);
      ctx.moveTo(px - size, py + size); ctx.lineTo(px + size, py - size);
      ctx.stroke();
    }
    ctx.restore();
  }

  function drawPane(p) {
    const pane = panes[p], canvas = pane.canvas, ep = paneEpisode(p);
    const dpr = window.devicePixelRatio || 1;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
      canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
    }
    const ctx = canvas.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const tr = transformFor(canvas, ep);
    pane.transform = tr;
    const t = Math.min(view.step, ep.rows - 1);
    const b = ep.meta.border;

    ctx.fillStyle = C.outside; ctx.fillRect(0, 0, w, h);
    const lo = toPx(tr, b[0], b[3]), hi = toPx(tr, b[2], b[1]);
    ctx.fillStyle = C.arena; ctx.fillRect(lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]);
    ctx.strokeStyle = "#000"; ctx.lineWidth = 1.5; ctx.strokeRect(lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]);

    for (let k = 0; k < ep.K; k++) {
      obstaclePath(ctx, tr, ep, k, t);
      ctx.fillStyle = rgb(ep.meta.obstacle_kind[k].startsWith("moving") ? C.moving_obstacle : C.static_obstacle);
      ctx.fill();
    }

    if (view.sensing) {
      ctx.setLineDash([4, 4]); ctx.lineWidth = 1;
      for (let a = 0; a < ep.A; a++) {
        const s = agentAt(ep, t, a), c = toPx(tr, s[0], s[1]);
        const colour = a < ep.N ? wolfColour(a) : C.target;
        ctx.strokeStyle = rgba(colour, 0.55); ctx.fillStyle = rgba(colour, 0.05);
        ctx.beginPath(); ctx.arc(c[0], c[1], ep.meta.sense_radius[a < ep.N ? 0 : 1] * tr.s, 0, 2 * Math.PI);
        ctx.fill(); ctx.stroke();
      }
      ctx.setLineDash([]);
    }

    if (view.trails) {
      ctx.lineWidth = 1.5; ctx.lineJoin = "round";
      for (let a = 0; a < ep.A; a++) {
        ctx.strokeStyle = rgba(a < ep.N ? wolfColour(a) : C.target, 0.6);
        ctx.beginPath();
        for (let u = Math.max(0, t - TRAIL); u <= t; u++) {
          const s = agentAt(ep, u, a), q = toPx(tr, s[0], s[1]);
          if (u === Math.max(0, t - TRAIL)) ctx.moveTo(q[0], q[1]); else ctx.lineTo(q[0], q[1]);
        }
        ctx.stroke();
      }
    }

    if (view.links && t > 0) {
      ctx.lineWidth = 1; ctx.strokeStyle = "rgba(0,0,0,0.35)";
      for (let i = 0; i < ep.A; i++) {
        for (let j = 0; j < ep.A; j++) {
          if (i === j || !linked(ep, t, i, j)) continue;
          const a = agentAt(ep, t, i), bb = agentAt(ep, t, j);
          const pa = toPx(tr, a[0], a[1]), pb = toPx(tr, bb[0], bb[1]);
          ctx.beginPath(); ctx.moveTo(pa[0], pa[1]); ctx.lineTo(pb[0], pb[1]); ctx.stroke();
        }
      }
    }

    // The clicked agent's lidar, under the bodies.
    if (view.lidar && view.selected && view.selected.pane === p && view.selected.agent < ep.A) {
      const s = agentAt(ep, t, view.selected.agent), c = toPx(tr, s[0], s[1]);
      const rays = lidar(ep, t, view.selected.agent), range = rays.length ? ep.meta.lidar[1] : 0;
      ctx.lineWidth = 1;
      rays.forEach(function (d, k) {
        const ang = s[2] + 2 * Math.PI * k / rays.length, q = toPx(tr, s[0] + d * Math.cos(ang), s[1] + d * Math.sin(ang));
        ctx.strokeStyle = d < range ? "rgba(20,20,20,0.7)" : "rgba(120,120,120,0.4)";
        ctx.beginPath(); ctx.moveTo(c[0], c[1]); ctx.lineTo(q[0], q[1]); ctx.stroke();
        if (d < range) { ctx.fillStyle = "#000"; ctx.strokeStyle = "#fff"; ctx.beginPath(); ctx.arc(q[0], q[1], 3, 0, 2 * Math.PI); ctx.fill(); ctx.stroke(); }
      });
    }

    // The hunting points, each joined to its wolf.
    if (view.hunting && ep.meta.hunting_radius) {
      ctx.lineWidth = 1;
      for (const [x, y, i] of hunting(ep, t)) {
        const q = toPx(tr, x, y), s = agentAt(ep, t, i), c = toPx(tr, s[0], s[1]);
        ctx.strokeStyle = rgba(wolfColour(i), 0.7); ctx.setLineDash([3, 3]);
        ctx.beginPath(); ctx.moveTo(c[0], c[1]); ctx.lineTo(q[0], q[1]); ctx.stroke();
        ctx.setLineDash([]); ctx.strokeStyle = rgb(wolfColour(i)); ctx.lineWidth = 1.5;
        ctx.beginPath(); ctx.arc(q[0], q[1], 3.5, 0, 2 * Math.PI); ctx.stroke();
        ctx.lineWidth = 1;
      }
    }

    // The capture ring around every target still hunted.
    ctx.setLineDash([5, 4]); ctx.lineWidth = 1.2; ctx.strokeStyle = rgb(C.target);
    for (let j = 0; j < ep.M; j++) {
      if (captured(ep, j, t)) continue;
      const s = agentAt(ep, t, ep.N + j), c = toPx(tr, s[0], s[1]);
      ctx.beginPath(); ctx.arc(c[0], c[1], ep.meta.capture_distance * tr.s, 0, 2 * Math.PI); ctx.stroke();
    }
    ctx.setLineDash([]);

    // Collisions, where and when (the episode ends at the step a wolf touched something),
    // under the bodies so that the wolf stays visible on its mark.
    if (ep.meta.collision_step >= 0 && t >= ep.meta.collision_step) {
      for (let i = 0; i < ep.N; i++) {
        if (!ep.meta.collisions[i]) continue;
        const s = agentAt(ep, ep.meta.collision_step, i), c = toPx(tr, s[0], s[1]);
        cross(ctx, c[0], c[1], 9);
      }
    }

    for (let j = 0; j < ep.M; j++) {
      const s = agentAt(ep, t, ep.N + j);
      bodyPath(ctx, tr, ep, s[0], s[1], s[2]);
      if (captured(ep, j, t)) { ctx.lineWidth = 2; ctx.strokeStyle = rgb(C.target); ctx.stroke(); }
      else { ctx.fillStyle = rgb(C.target); ctx.fill(); }
    }
    for (let i = 0; i < ep.N; i++) {
      const s = agentAt(ep, t, i);
      bodyPath(ctx, tr, ep, s[0], s[1], s[2]);
      ctx.fillStyle = rgb(wolfColour(i)); ctx.fill();
    }

    if (view.selected && view.selected.pane === p && view.selected.agent < ep.A) {
      const s = agentAt(ep, t, view.selected.agent), c = toPx(tr, s[0], s[1]);
      ctx.strokeStyle = "#000"; ctx.lineWidth = 1.5; ctx.setLineDash([2, 2]);
      ctx.beginPath(); ctx.arc(c[0], c[1], Math.max(12, ep.meta.body[0] * tr.s * 1.6), 0, 2 * Math.PI); ctx.stroke();
      ctx.setLineDash([]);
    }

    const label = "step " + t + " / " + (ep.rows - 1) + "   t = " + (t * ep.meta.ts).toFixed(1) + " s" + (t < view.step ? "   (ended)" : "");
    ctx.font = "12px system-ui, sans-serif"; ctx.textBaseline = "middle";
    ctx.fillStyle = "rgba(255,255,255,0.85)"; ctx.fillRect(4, 4, ctx.measureText(label).width + 10, 18);
    ctx.fillStyle = "#000"; ctx.fillText(label, 9, 13);
  }

  // --- the outcome timeline ----------------------------------------------------------------

  function events(ep) {
    const m = ep.meta, out = [];
    if (m.first_sighting >= 0) out.push({ step: m.first_sighting, kind: "first sighting" });
    if (m.cornered_step >= 0) out.push({ step: m.cornered_step, kind: "cornered" });
    m.target_capture_step.forEach(function (s, j) {
      if (s >= 0 && m.outcome === "captured") out.push({ step: s, kind: "capture" + (ep.M > 1 ? " of target " + j : "") });
    });
    if (m.collision_step >= 0) out.push({ step: m.collision_step, kind: "collision" });
    // The end first, so that an event on the last step (a capture, a collision) is drawn over it.
    out.unshift({ step: ep.rows - 1, kind: "end: " + m.outcome });
    return out;
  }
  function eventColour(kind) {
    if (kind === "first sighting") return C.sighting;
    if (kind === "cornered") return C.outcomes.cornered;
    if (kind.startsWith("capture")) return C.outcomes.captured;
    if (kind === "collision") return C.outcomes.collision;
    return "#555";
  }

  function drawTimeline() {
    const canvas = document.getElementById("timeline");
    const dpr = window.devicePixelRatio || 1;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
    const ctx = canvas.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, w, h);
    const last = Math.max(1, lastStep());
    // The range input's thumb centre runs from half a thumb in from each end.
    const pad = 8, x = function (s) { return pad + (w - 2 * pad) * s / last; };
    const n = item().episodes.length, band = h / n;
    for (let p = 0; p < n; p++) {
      const ep = paneEpisode(p), y0 = p * band;
      ctx.fillStyle = "#e8e8e4"; ctx.fillRect(x(0), y0 + band * 0.35, x(ep.rows - 1) - x(0), band * 0.3);
      for (const ev of events(ep)) {
        ctx.fillStyle = eventColour(ev.kind);
        ctx.fillRect(x(ev.step) - 2, y0 + 1, 4, band - 2);
      }
    }
    ctx.fillStyle = "#000"; ctx.fillRect(x(view.step) - 0.5, 0, 1, h);
  }

  // --- the clicked agent -------------------------------------------------------------------

  function showInfo() {
    const box = document.getElementById("info");
    if (!view.selected || view.selected.pane >= panes.length) return;
    const p = view.selected.pane, a = view.selected.agent, ep = paneEpisode(p);
    if (a >= ep.A) return;
    const t = Math.min(view.step, ep.rows - 1), s = agentAt(ep, t, a);
    const senses = [];
    for (let j = 0; j < ep.A; j++) if (j !== a && linked(ep, t, a, j)) senses.push(agentName(ep, j));
    const rows = [
      ["step", t + (panes.length > 1 ? " (" + panes[p].name + ")" : "")],
      ["law", a < ep.N ? ep.meta.wolf_law : ep.meta.target_law],
      ["position", s[0].toFixed(3) + ", " + s[1].toFixed(3) + " m"],
      ["heading", s[2].toFixed(3) + " rad (" + (s[2] * 180 / Math.PI).toFixed(1) + "\u00b0)"],
      ["speed", s[3].toFixed(3) + " m/s"],
      ["turn rate", s[4].toFixed(3) + " rad/s"],
      ["energy", ep.energy[t * ep.A + a].toFixed(3) + " J"],
      ["senses", t === 0 ? "(from step 1)" : (senses.join(", ") || "nothing")],
      ["contacts", ep.meta.collisions[a] + " steps in contact, over the episode"],
    ];
    const rays = lidar(ep, t, a);
    if (rays.length) {
      const hits = rays.filter(function (d) { return d < ep.meta.lidar[1]; });
      rows.push(["lidar", rays.length + " rays, " + (hits.length ? hits.length + " hit, nearest " + Math.min.apply(null, hits).toFixed(2) + " m" : "nothing within " + ep.meta.lidar[1] + " m")]);
    }
    if (a < ep.N) {
      const point = hunting(ep, t).find(function (h) { return h[2] === a; });
      if (point) rows.push(["hunting point", point[0].toFixed(2) + ", " + point[1].toFixed(2) + " m (" + Math.hypot(point[0] - s[0], point[1] - s[1]).toFixed(2) + " m away)"]);
    }
    if (a >= ep.N) {
      const end = ep.meta.target_capture_step[a - ep.N];
      rows.push(["hunt", end >= 0 && end <= t ? "ended at step " + end : "going on"]);
    }
    const mode = modeName(ep, t, a);
    if (mode !== null) rows.splice(2, 0, ["mode", t === 0 ? "(from step 1)" : mode === "none" ? "none (no law drove it)" : mode]);
    const colour = a < ep.N ? wolfColour(a) : C.target;
    box.innerHTML = "";
    const head = document.createElement("b");
    head.textContent = agentName(ep, a);
    head.style.color = rgb(colour);
    box.appendChild(head);
    const table = document.createElement("table");
    table.id = "agent-state";
    for (const [k, v] of rows) {
      const tr = table.insertRow();
      tr.insertCell().textContent = k;
      tr.insertCell().textContent = v;
    }
    box.appendChild(table);
  }

  function pick(p, px, py) {
    const ep = paneEpisode(p), tr = panes[p].transform, t = Math.min(view.step, ep.rows - 1);
    let best = null, bestD = Math.max(12, ep.meta.body[0] * tr.s * 1.5);
    for (let a = 0; a < ep.A; a++) {
      const s = agentAt(ep, t, a), c = toPx(tr, s[0], s[1]);
      const d = Math.hypot(c[0] - px, c[1] - py);
      if (d < bestD) { best = a; bestD = d; }
    }
    return best;
  }

  // --- layout, list and controls ----------------------------------------------------------

  function outcomeBadge(meta, prefix) {
    const span = document.createElement("span");
    span.className = "badge";
    span.style.background = C.outcomes[meta.outcome] || "#555";
    const when = meta.outcome === "captured" ? " @" + meta.capture_step : " " + meta.steps;
    span.textContent = (prefix ? prefix + ": " : "") + meta.outcome + when;
    return span;
  }

  function buildList() {
    const list = document.getElementById("list");
    DATA.items.forEach(function (it, k) {
      const li = document.createElement("li");
      li.dataset.item = k;
      const name = document.createElement("div");
      name.textContent = it.label;
      li.appendChild(name);
      const badges = document.createElement("div");
      badges.className = "badges";
      it.episodes.forEach(function (e, p) { badges.appendChild(outcomeBadge(DATA.episodes[e], DATA.panes ? DATA.panes[p] : "")); });
      li.appendChild(badges);
      li.addEventListener("click", function () { selectItem(k); });
      list.appendChild(li);
    });
    if (DATA.items.length < 2) list.style.display = "none";
  }

  function buildPanes() {
    const holder = document.getElementById("panes");
    holder.innerHTML = "";
    panes.length = 0;
    item().episodes.forEach(function (e, p) {
      const div = document.createElement("div");
      div.className = "pane";
      const caption = document.createElement("div");
      caption.className = "caption";
      const meta = DATA.episodes[e];
      const name = DATA.panes ? DATA.panes[p] : meta.label;
      caption.textContent = name + (name.indexOf("seed") >= 0 ? "" : " \u2014 seed " + meta.seed) + ": " + meta.outcome + (meta.outcome === "captured" ? " at step " + meta.capture_step : " after " + meta.steps + " steps");
      const canvas = document.createElement("canvas");
      canvas.dataset.pane = p;
      div.appendChild(caption); div.appendChild(canvas);
      holder.appendChild(div);
      panes.push({ div: div, canvas: canvas, caption: caption, name: name, transform: null });
      hookCanvas(canvas, p);
    });
    const hunted = item().episodes.some(function (e) { return DATA.episodes[e].hunting_radius; });
    document.getElementById("hunting-toggle").style.display = hunted ? "" : "none";
  }

  function hookCanvas(canvas, p) {
    let drag = null;
    canvas.addEventListener("pointerdown", function (ev) {
      drag = { x: ev.clientX, y: ev.clientY, moved: false };
      canvas.setPointerCapture(ev.pointerId);
    });
    canvas.addEventListener("pointermove", function (ev) {
      if (!drag) return;
      const dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
      if (!drag.moved && Math.hypot(dx, dy) < 4) return;
      drag.moved = true;
      canvas.classList.add("dragging");
      const tr = panes[p].transform, c = centre(p);
      view.cx = c[0] - dx / tr.s; view.cy = c[1] + dy / tr.s;
      drag.x = ev.clientX; drag.y = ev.clientY;
      draw();
    });
    canvas.addEventListener("pointerup", function (ev) {
      canvas.classList.remove("dragging");
      if (drag && !drag.moved) {
        const r = canvas.getBoundingClientRect();
        const a = pick(p, ev.clientX - r.left, ev.clientY - r.top);
        view.selected = a === null ? null : { pane: p, agent: a };
        if (a === null) document.getElementById("info").innerHTML = '<span class="hint">No agent there: click a wolf or a target.</span>';
        draw();
      }
      drag = null;
    });
    canvas.addEventListener("wheel", function (ev) {
      ev.preventDefault();
      const r = canvas.getBoundingClientRect();
      zoomAt(p, ev.deltaY < 0 ? 1.2 : 1 / 1.2, ev.clientX - r.left, ev.clientY - r.top);
    }, { passive: false });
  }

  function centre(p) {
    const ep = paneEpisode(p), b = ep.meta.border;
    return [view.cx === null ? (b[0] + b[2]) / 2 : view.cx, view.cy === null ? (b[1] + b[3]) / 2 : view.cy];
  }

  // Zoom by `factor`, keeping the world point under (px, py) of pane p where it is.
  function zoomAt(p, factor, px, py) {
    const tr = panes[p].transform;
    const z = Math.min(40, Math.max(0.5, view.zoom * factor));
    if (!tr) { view.zoom = z; draw(); return; }
    const wpt = px === undefined ? centre(p) : toWorld(tr, px, py);
    const c = centre(p), k = view.zoom / z;
    view.cx = wpt[0] + (c[0] - wpt[0]) * k;
    view.cy = wpt[1] + (c[1] - wpt[1]) * k;
    view.zoom = z;
    draw();
  }

  // Zoom from the keys and buttons: around the clicked agent when there is one, so that it stays
  // in view; else around the panes' centre.
  function zoomKey(factor) {
    const sel = view.selected;
    if (sel && sel.pane < panes.length && panes[sel.pane].transform) {
      const ep = paneEpisode(sel.pane), s = agentAt(ep, Math.min(view.step, ep.rows - 1), sel.agent);
      const q = toPx(panes[sel.pane].transform, s[0], s[1]);
      zoomAt(sel.pane, factor, q[0], q[1]);
    } else {
      zoomAt(0, factor);
    }
  }

  function buildLegend() {
    const legend = document.getElementById("legend");
    const entries = [["first sighting", C.sighting], ["cornered", C.outcomes.cornered], ["capture", C.outcomes.captured], ["collision", C.outcomes.collision], ["end", "#555"]];
    for (const [name, colour] of entries) {
      const span = document.createElement("span");
      span.textContent = name;
      span.style.setProperty("--c", colour);
      legend.appendChild(span);
    }
  }

  function draw() {
    for (let p = 0; p < panes.length; p++) drawPane(p);
    drawTimeline();
    const scrub = document.getElementById("scrub");
    scrub.max = lastStep();
    scrub.value = view.step;
    const ts = paneEpisode(0).meta.ts;
    document.getElementById("step-label").textContent = "step " + view.step + " / " + lastStep() + " (" + (view.step * ts).toFixed(1) + " s)";
    document.getElementById("play").innerHTML = view.playing ? "&#10074;&#10074;" : "&#9654;";
    showInfo();
  }

  function setStep(s) {
    view.step = Math.max(0, Math.min(lastStep(), Math.round(s)));
    draw();
  }

  function selectItem(k) {
    if (k < 0 || k >= DATA.items.length) return;
    view.item = k;
    view.step = Math.min(view.step, lastStep());
    view.selected = null;
    document.getElementById("info").innerHTML = '<span class="hint">Click a wolf or a target for its state.</span>';
    document.querySelectorAll("#list li").forEach(function (li) { li.classList.toggle("current", Number(li.dataset.item) === k); });
    const current = document.querySelector("#list li.current");
    if (current && current.scrollIntoView) current.scrollIntoView({ block: "nearest" });
    buildPanes();
    draw();
    // The address names the item shown, so that it can be shared (no reload, no history entry).
    if (ready && history.replaceState) history.replaceState(null, "", "#item=" + k);
  }

  // --- the table whose cells open episodes (matrix, scorecard) -----------------------------

  function buildTable() {
    const t = DATA.table, holder = document.getElementById("table-view");
    const table = document.createElement("table");
    table.id = "cells";
    const caption = table.createCaption();
    caption.textContent = t.caption;
    const head = table.createTHead().insertRow();
    const corner = document.createElement("th");
    corner.textContent = t.corner || "";
    head.appendChild(corner);
    for (const c of t.columns) { const th = document.createElement("th"); th.textContent = c; head.appendChild(th); }
    const body = table.createTBody();
    t.rows.forEach(function (name, r) {
      const tr = body.insertRow();
      const th = document.createElement("th");
      th.textContent = name;
      tr.appendChild(th);
      t.cells[r].forEach(function (cell, c) {
        const td = tr.insertCell();
        td.textContent = cell.text;
        td.title = cell.title || "";
        if (cell.value !== null && cell.value !== undefined) {
          const g = C.outcomes.captured;
          td.style.background = "color-mix(in srgb, " + g + " " + Math.round(70 * cell.value) + "%, white)";
        }
        if (cell.item !== null && cell.item !== undefined) {
          td.className = "cell";
          td.dataset.item = cell.item;
          td.dataset.row = r; td.dataset.column = c;
          td.addEventListener("click", function () { showTable(false); selectItem(cell.item); });
        }
      });
    });
    holder.appendChild(table);
    document.getElementById("to-table").addEventListener("click", function () { showTable(true); });
  }
  function showTable(on) {
    if (!DATA.table) return;
    if (on) setPlaying(false);
    document.body.classList.toggle("table-mode", on);
    document.getElementById("table-view").hidden = !on;
    document.getElementById("to-table").hidden = on;
    if (!on) draw();
  }
  function tableShown() { return Boolean(DATA.table) && document.body.classList.contains("table-mode"); }

  // --- playing ---------------------------------------------------------------------------

  let clock = null, owed = 0;
  function tick(now) {
    if (!view.playing) { clock = null; return; }
    if (clock !== null) {
      owed += (now - clock) / 1000 * view.speed / paneEpisode(0).meta.ts;
      const whole = Math.floor(owed);
      if (whole > 0) {
        owed -= whole;
        if (view.step + whole >= lastStep()) { view.step = lastStep(); view.playing = false; }
        else view.step += whole;
        draw();
      }
    }
    clock = now;
    if (view.playing) requestAnimationFrame(tick); else { clock = null; draw(); }
  }
  function setPlaying(on) {
    if (on && view.step >= lastStep()) view.step = 0;
    view.playing = on;
    owed = 0;
    if (on && clock === null) requestAnimationFrame(tick);
    draw();
  }

  function hookControls() {
    document.getElementById("play").addEventListener("click", function () { setPlaying(!view.playing); });
    document.getElementById("back").addEventListener("click", function () { setPlaying(false); setStep(view.step - 1); });
    document.getElementById("forward").addEventListener("click", function () { setPlaying(false); setStep(view.step + 1); });
    document.getElementById("scrub").addEventListener("input", function (ev) { setStep(Number(ev.target.value)); });
    document.getElementById("speed").addEventListener("change", function (ev) { view.speed = Number(ev.target.value); });
    document.getElementById("zoom-in").addEventListener("click", function () { zoomKey(1.25); });
    document.getElementById("zoom-out").addEventListener("click", function () { zoomKey(1 / 1.25); });
    document.getElementById("zoom-reset").addEventListener("click", resetView);
    for (const [id, key] of [["show-trails", "trails"], ["show-sensing", "sensing"], ["show-links", "links"], ["show-lidar", "lidar"], ["show-hunting", "hunting"]]) {
      const box = document.getElementById(id);
      view[key] = box.checked;
      box.addEventListener("change", function () { view[key] = box.checked; draw(); });
    }
    // Hovering the timeline names the events under the pointer.
    document.getElementById("timeline").addEventListener("mousemove", function (ev) {
      const r = ev.target.getBoundingClientRect(), last = Math.max(1, lastStep());
      const step = Math.round((ev.clientX - r.left - 8) / (r.width - 16) * last), near = Math.max(1, last / 100);
      const lines = [];
      for (let p = 0; p < item().episodes.length; p++) {
        for (const e of events(paneEpisode(p))) {
          if (Math.abs(e.step - step) <= near) lines.push((panes.length > 1 ? panes[p].name + ": " : "") + e.kind + " at step " + e.step);
        }
      }
      ev.target.title = lines.length ? lines.join("\n") : "step " + Math.max(0, Math.min(last, step)) + " (click to go there)";
    });
    document.getElementById("timeline").addEventListener("click", function (ev) {
      const r = ev.target.getBoundingClientRect();
      setStep((ev.clientX - r.left - 8) / (r.width - 16) * lastStep());
    });
    window.addEventListener("keydown", function (ev) {
      if (ev.target && ev.target.tagName === "SELECT") return;
      if (ev.key === "t" && DATA.table) { showTable(!tableShown()); ev.preventDefault(); return; }
      if (tableShown()) return;
      const big = ev.shiftKey ? 10 : 1;
      let done = true;
      switch (ev.key) {
        case " ": setPlaying(!view.playing); break;
        case "ArrowRight": setPlaying(false); setStep(view.step + big); break;
        case "ArrowLeft": setPlaying(false); setStep(view.step - big); break;
        case "Home": setStep(0); break;
        case "End": setStep(lastStep()); break;
        case "+": case "=": zoomKey(1.25); break;
        case "-": case "_": zoomKey(1 / 1.25); break;
        case "0": resetView(); break;
        case "]": case "PageDown": selectItem(view.item + 1); break;
        case "[": case "PageUp": selectItem(view.item - 1); break;
        case ">": setSpeed(1); break;
        case "<": setSpeed(-1); break;
        default: done = false;
      }
      if (done) ev.preventDefault();
    });
    window.addEventListener("resize", draw);
    window.addEventListener("hashchange", fromHash);
  }
  function setSpeed(dir) {
    const i = Math.max(0, Math.min(SPEEDS.length - 1, SPEEDS.indexOf(view.speed) + dir));
    view.speed = SPEEDS[i];
    document.getElementById("speed").value = String(view.speed);
  }
  function resetView() { view.zoom = 1; view.cx = null; view.cy = null; draw(); }

  // #item=K&step=T opens item K at step T (the list pages link episodes this way).
  function fromHash() {
    const q = new URLSearchParams(location.hash.replace(/^#/, ""));
    if (q.has("item")) { showTable(false); selectItem(Number(q.get("item")) || 0); }
    if (q.has("step")) setStep(Number(q.get("step")) || 0);
  }

  // --- the script interface (read-only) ----------------------------------------------------

  function checkPane(pane) {
    const p = pane === undefined ? 0 : pane;
    if (!(p >= 0 && p < panes.length)) throw new RangeError("pane " + pane + ": the item shown has " + panes.length);
    return p;
  }
  let ready = false;
  const api = {
    get ready() { return ready; },
    version: DATA.version,
    // {step, wolves: [[x, y, heading], ...], targets: [...], wolf_modes: [name, ...],
    // target_modes: [...]} (m, rad) of the episode shown in pane `pane` (default 0) at `step`
    // (clamped to the episode; default the step shown). A mode is the name of the mode each
    // agent's law was in at the step that led to this state ("none" at step 0 and where no law
    // drove it); wolf_modes and target_modes are null where the episode records no modes.
    state: function (step, pane) {
      const ep = paneEpisode(checkPane(pane));
      const t = Math.max(0, Math.min(ep.rows - 1, step === undefined ? view.step : Math.round(step)));
      const pick3 = function (a) { return agentAt(ep, t, a).slice(0, 3); };
      const wolves = [], targets = [];
      for (let i = 0; i < ep.N; i++) wolves.push(pick3(i));
      for (let j = 0; j < ep.M; j++) targets.push(pick3(ep.N + j));
      const modes = function (from, count) {
        if (!ep.modes) return null;
        const out = [];
        for (let a = from; a < from + count; a++) out.push(modeName(ep, t, a));
        return out;
      };
      return { step: t, wolves: wolves, targets: targets, wolf_modes: modes(0, ep.N), target_modes: modes(ep.N, ep.M) };
    },
    step: function () { return view.step; },
    lastStep: function () { return lastStep(); },
    playing: function () { return view.playing; },
    item: function () { return view.item; },
    items: function () { return DATA.items.length; },
    episodes: function () { return DATA.episodes.length; },
    panes: function () { return panes.length; },
    // Where the world point (x, y) is drawn, in CSS pixels from the viewport's top left.
    toScreen: function (x, y, pane) {
      const p = checkPane(pane), r = panes[p].canvas.getBoundingClientRect(), q = toPx(panes[p].transform, x, y);
      return [r.left + q[0], r.top + q[1]];
    },
    // [[x, y, wolf], ...]: the wolves' hunting points at `step` ([] where the law and the
    // capture rule have none).
    hunting: function (step, pane) {
      const ep = paneEpisode(checkPane(pane));
      return hunting(ep, Math.max(0, Math.min(ep.rows - 1, Math.round(step))));
    },
    // The lidar distances (m) of agent `agent` (wolves first, then targets) at `step`.
    lidar: function (step, agent, pane) {
      const ep = paneEpisode(checkPane(pane));
      if (!(agent >= 0 && agent < ep.A)) throw new RangeError("agent " + agent + ": the episode has " + ep.A);
      return lidar(ep, Math.max(0, Math.min(ep.rows - 1, Math.round(step))), agent);
    },
    colours: function () { return JSON.parse(JSON.stringify(C)); },
    selected: function () { return view.selected ? Object.assign({}, view.selected) : null; },
    // "table" while a matrix's or scorecard's table is shown, else "episode".
    showing: function () { return tableShown() ? "table" : "episode"; },
  };
  Object.freeze(api);
  Object.defineProperty(window, "wolfpack", { value: api, writable: false, configurable: false });

  // --- start -------------------------------------------------------------------------------

  try {
    document.getElementById("subtitle").textContent = DATA.subtitle || "";
    buildList();
    buildLegend();
    hookControls();
    selectItem(0);
    if (DATA.table) { buildTable(); showTable(true); }
    fromHash();
    ready = true;
  } catch (err) {
    const box = document.createElement("div");
    box.id = "error";
    box.textContent = "This page could not show its episodes: " + err.message;
    document.body.prepend(box);
    throw err;
  }
})();
