// occmap web: the live page (docs/web.md). One WebSocket to the server that served this page:
// binary messages are maps (the newest is drawn at the next animation frame, older ones that
// arrive meanwhile are dropped), text messages are JSON: "hello", "daemons", "zones", "tracks",
// "previews" (which cameras have a new preview: their pictures are fetched again).
// The page reconnects by itself when the server goes away and comes back, and says when no map
// has come for a while (the daemon stopped). Everything from the network is shown as text
// (textContent), never as markup.
'use strict';

(() => {
  // The README's colours (tools/pictures.cpp): free, occupied, unseen; and `occmap view`'s for
  // zones (free, occupied, unseen), tracks and footprints (tools/footprint_pictures.h).
  const CELL_RGB = [[245, 245, 245], [35, 35, 35], [120, 140, 170], [255, 0, 255]];
  const ZONE_COLOURS = ['#3caa3c', '#dc2828', '#ffaa00'];
  const ZONE_UNKNOWN = '#c83cc8';
  const TRACK_COLOUR = '#005ac8';
  const FOOTPRINT_COLOUR = '#8c8c00';
  const TRAIL_SECONDS = 5;       // a track's trail: where it was over the last seconds
  const ARROW_SECONDS = 1;       // a track's arrow: one second of its motion
  const STALE_MAP_MS = 2000;     // no map for this long: said in the header
  const SILENT_SOCKET_MS = 5000; // nothing at all for this long (the server sends every second): reconnect
  const SILENT_DAEMON_S = 3;     // a daemon not heard for this long is shown as silent
  const MAP_FRAME_MAGIC = [0x4f, 0x4d, 0x41, 0x50]; // "OMAP"

  const $ = (id) => document.getElementById(id);

  const page = {
    socket: null,
    retries: 0,
    lastMessageAt: 0,
    pendingMap: null,   // the newest map not yet drawn (an ArrayBuffer)
    mapsReceived: 0,
    mapsDropped: 0,     // received but replaced by a newer one before they were drawn
    mapTimes: [],       // arrival times over the last second, for maps/s
    lastMapAt: 0,
    drawn: null,        // the map on the canvas: seq, geometry, scale
    offscreen: null,
    image: null,
    zones: null,
    tracks: null,
    trails: new Map(),  // track id -> [{x, y, t}]
    lastTracksSeq: null,
    overlayDirty: false,
    listsDirty: false,
    daemons: [],
    daemonsDirty: false,
    hello: null,
    cameraCards: '',
    previews: new Map(),   // "host\ncamera" -> the newest preview's facts (from "previews")
    previewsDirty: false,
    highlighted: null,     // [host, camera] whose cells are drawn over the map
  };
  const COVERAGE_REFRESH_MS = 5000;

  // ---- numbers and text -------------------------------------------------------------------

  const fixed = (value, digits) =>
    typeof value === 'number' && Number.isFinite(value) ? value.toFixed(digits) : '–';
  const count = (value) => (typeof value === 'number' ? value.toLocaleString('en') : '–');
  function duration(seconds) {
    if (typeof seconds !== 'number' || !Number.isFinite(seconds)) return '–';
    if (seconds < 60) return seconds.toFixed(1) + ' s';
    const s = Math.floor(seconds);
    const h = Math.floor(s / 3600);
    const m = Math.floor((s % 3600) / 60);
    return h + ':' + String(m).padStart(2, '0') + ':' + String(s % 60).padStart(2, '0');
  }
  function element(tag, text, className) {
    const e = document.createElement(tag);
    if (text !== undefined && text !== null) e.textContent = String(text);
    if (className) e.className = className;
    return e;
  }
  function row(cells) {
    const tr = document.createElement('tr');
    for (const cell of cells) {
      if (cell instanceof Node) {
        const td = document.createElement('td');
        td.appendChild(cell);
        tr.appendChild(td);
      } else if (cell && typeof cell === 'object') {
        tr.appendChild(element('td', cell.text, cell.className));
      } else {
        tr.appendChild(element('td', cell));
      }
    }
    return tr;
  }
  const num = (text) => ({ text, className: 'number' });
  function headRow(names) {
    const tr = document.createElement('tr');
    for (const name of names) tr.appendChild(element('th', name));
    return tr;
  }

  // ---- the connection ---------------------------------------------------------------------

  function setConnection(state, text) {
    document.body.dataset.connection = state;
    $('connection').textContent = text;
  }

  function connect() {
    const url = (location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/ws';
    let socket;
    try {
      socket = new WebSocket(url);
    } catch (e) {
      reconnectLater();
      return;
    }
    socket.binaryType = 'arraybuffer';
    page.socket = socket;
    page.lastMessageAt = performance.now();
    setConnection('connecting', 'connecting…');
    socket.onopen = () => {
      page.retries = 0;
      setConnection('open', 'connected');
    };
    socket.onmessage = (event) => {
      page.lastMessageAt = performance.now();
      if (typeof event.data === 'string') {
        onText(event.data);
        return;
      }
      if (page.pendingMap) page.mapsDropped++;
      page.pendingMap = event.data;
      page.mapsReceived++;
      page.lastMapAt = page.lastMessageAt;
      page.mapTimes.push(page.lastMapAt);
    };
    socket.onclose = () => {
      if (page.socket !== socket) return;
      page.socket = null;
      reconnectLater();
    };
  }

  function reconnectLater() {
    // 0.25 s, 0.5 s, 1 s, 2 s, then every 4 s: back soon after the server is.
    const delay = Math.min(4000, 250 * 2 ** page.retries);
    page.retries++;
    setConnection('closed', 'disconnected: trying again in ' + (delay / 1000).toFixed(1) + ' s');
    setTimeout(connect, delay);
  }

  // A connection that says nothing (a server gone without closing it) is given up on.
  setInterval(() => {
    if (page.socket && page.socket.readyState === WebSocket.OPEN &&
        performance.now() - page.lastMessageAt > SILENT_SOCKET_MS) {
      const socket = page.socket;
      page.socket = null;
      socket.close();
      reconnectLater();
    }
  }, 1000);

  function onText(text) {
    let message;
    try {
      message = JSON.parse(text);
    } catch (e) {
      return;
    }
    if (!message || typeof message !== 'object') return;
    switch (message.type) {
      case 'hello':
        page.hello = message;
        $('bus-info').textContent = 'listening at ' + message.lcm_url + ': maps on ' +
            message.map_channel + ', statuses on ' + message.status_channel;
        break;
      case 'daemons':
        page.daemons = Array.isArray(message.daemons) ? message.daemons : [];
        page.daemonsDirty = true;
        break;
      case 'zones':
        page.zones = message.zones;
        page.overlayDirty = page.listsDirty = true;
        break;
      case 'tracks':
        takeTracks(message.tracks);
        page.overlayDirty = page.listsDirty = true;
        break;
      case 'previews':
        page.previews = new Map();
        for (const p of Array.isArray(message.previews) ? message.previews : []) {
          if (p && typeof p.hostname === 'string' && typeof p.camera === 'string') {
            page.previews.set(p.hostname + '\n' + p.camera, p);
          }
        }
        page.previewsDirty = true;
        break;
    }
  }

  function takeTracks(tracks) {
    page.tracks = tracks;
    if (!tracks || !Array.isArray(tracks.tracks)) return;
    // A daemon that restarted numbers its maps and its tracks from the start again.
    if (page.lastTracksSeq !== null && tracks.seq >= 0 && tracks.seq < page.lastTracksSeq) {
      page.trails.clear();
    }
    if (tracks.seq >= 0) page.lastTracksSeq = tracks.seq;
    const now = performance.now() / 1000;
    for (const track of tracks.tracks) {
      let trail = page.trails.get(track.id);
      if (!trail) page.trails.set(track.id, (trail = []));
      trail.push({ x: track.x_m, y: track.y_m, t: now });
    }
    for (const [id, trail] of page.trails) {
      while (trail.length && trail[0].t < now - TRAIL_SECONDS) trail.shift();
      if (!trail.length) page.trails.delete(id);
    }
  }

  // ---- the map ----------------------------------------------------------------------------

  // A binary map message (web/map_wire.h), or null when it is not one.
  function decodeMapFrame(buffer) {
    if (!(buffer instanceof ArrayBuffer) || buffer.byteLength < 64) return null;
    const v = new DataView(buffer);
    for (let k = 0; k < 4; k++) if (v.getUint8(k) !== MAP_FRAME_MAGIC[k]) return null;
    if (v.getUint8(4) !== 1 || v.getUint8(5) !== 1) return null;
    const headerSize = v.getUint16(6, true);
    const width = v.getUint32(8, true);
    const height = v.getUint32(12, true);
    if (headerSize < 64 || width < 1 || height < 1 || width > 8192 || height > 8192) return null;
    if (buffer.byteLength !== headerSize + Math.ceil((width * height) / 4)) return null;
    return {
      seq: Number(v.getBigInt64(16, true)),
      utime: Number(v.getBigInt64(24, true)),
      cellSize: v.getFloat64(32, true),
      originX: v.getFloat64(40, true),
      originY: v.getFloat64(48, true),
      recvUtime: Number(v.getBigInt64(56, true)),
      width,
      height,
      cells: new Uint8Array(buffer, headerSize),
    };
  }

  // Whole pixels per cell, so that each cell is a square of one colour: as large as the panel
  // allows (at least one).
  function pixelsPerCell(map) {
    const room = Math.max(200, Math.min($('map-panel').clientWidth - 24, 1024));
    return Math.max(1, Math.floor(room / Math.max(map.width, map.height)));
  }

  function drawMap(map) {
    if (!page.offscreen || page.offscreen.width !== map.width ||
        page.offscreen.height !== map.height) {
      page.offscreen = document.createElement('canvas');
      page.offscreen.width = map.width;
      page.offscreen.height = map.height;
      page.image = new ImageData(map.width, map.height);
    }
    const rgba = page.image.data;
    const cells = map.cells;
    // Map row 0 is the smallest y: it goes at the bottom (+y up).
    for (let r = 0; r < map.height; r++) {
      let i = r * map.width;
      let o = (map.height - 1 - r) * map.width * 4;
      for (let c = 0; c < map.width; c++, i++, o += 4) {
        const rgb = CELL_RGB[(cells[i >> 2] >> ((i & 3) << 1)) & 3];
        rgba[o] = rgb[0];
        rgba[o + 1] = rgb[1];
        rgba[o + 2] = rgb[2];
        rgba[o + 3] = 255;
      }
    }
    page.offscreen.getContext('2d').putImageData(page.image, 0, 0);
    const scale = pixelsPerCell(map);
    const canvas = $('map');
    const overlay = $('overlay');
    const w = map.width * scale;
    const h = map.height * scale;
    if (canvas.width !== w || canvas.height !== h) {
      canvas.width = overlay.width = w;
      canvas.height = overlay.height = h;
    }
    const context = canvas.getContext('2d');
    context.imageSmoothingEnabled = false;
    context.drawImage(page.offscreen, 0, 0, w, h);
    page.drawn = {
      seq: map.seq, utime: map.utime, width: map.width, height: map.height, scale,
      cellSize: map.cellSize, originX: map.originX, originY: map.originY,
    };
    canvas.dataset.seq = String(map.seq);
    document.body.dataset.drawn = 'yes';
    page.overlayDirty = true;
  }

  // Floor point (metres) -> overlay pixel.
  function toPixel(d, x, y) {
    return [((x - d.originX) / d.cellSize) * d.scale,
            (d.height - (y - d.originY) / d.cellSize) * d.scale];
  }

  function label(context, text, x, y, colour) {
    context.font = '12px system-ui, sans-serif';
    context.lineWidth = 3;
    context.strokeStyle = 'rgba(255,255,255,0.9)';
    context.strokeText(text, x, y);
    context.fillStyle = colour;
    context.fillText(text, x, y);
  }

  function drawOverlay() {
    const d = page.drawn;
    const overlay = $('overlay');
    const context = overlay.getContext('2d');
    context.clearRect(0, 0, overlay.width, overlay.height);
    if (!d) return;
    // Zones: the polygon in its state's colour, its name and state beside it.
    const zones = page.zones && Array.isArray(page.zones.zones) ? page.zones.zones : [];
    for (const zone of zones) {
      const xs = zone.corner_x_m || [];
      const ys = zone.corner_y_m || [];
      if (xs.length < 3 || xs.length !== ys.length) continue;
      const colour = ZONE_COLOURS[zone.state] || ZONE_UNKNOWN;
      context.beginPath();
      let top = Infinity;
      let left = Infinity;
      xs.forEach((x, k) => {
        const [px, py] = toPixel(d, x, ys[k]);
        if (k === 0) context.moveTo(px, py); else context.lineTo(px, py);
        top = Math.min(top, py);
        left = Math.min(left, px);
      });
      context.closePath();
      context.globalAlpha = 0.12;
      context.fillStyle = colour;
      context.fill();
      context.globalAlpha = 1;
      context.lineWidth = 2;
      context.strokeStyle = colour;
      context.stroke();
      label(context, zone.name + ' ' + zone.state_name, left, top > 18 ? top - 5 : top + 14, colour);
    }
    // Tracks: the trail, the footprints found on the map, each track's dot, id and arrow.
    context.lineWidth = 2;
    for (const trail of page.trails.values()) {
      if (trail.length < 2) continue;
      context.beginPath();
      trail.forEach((p, k) => {
        const [px, py] = toPixel(d, p.x, p.y);
        if (k === 0) context.moveTo(px, py); else context.lineTo(px, py);
      });
      context.strokeStyle = 'rgba(0,90,200,0.45)';
      context.stroke();
    }
    const tracks = page.tracks;
    if (tracks && Array.isArray(tracks.footprints)) {
      context.strokeStyle = FOOTPRINT_COLOUR;
      for (const f of tracks.footprints) {
        const [px, py] = toPixel(d, f.x_m, f.y_m);
        context.beginPath();
        context.arc(px, py, 9, 0, 2 * Math.PI);
        context.stroke();
      }
    }
    if (tracks && Array.isArray(tracks.tracks)) {
      for (const t of tracks.tracks) {
        const [px, py] = toPixel(d, t.x_m, t.y_m);
        const [ex, ey] = toPixel(d, t.x_m + t.vx_m_s * ARROW_SECONDS, t.y_m + t.vy_m_s * ARROW_SECONDS);
        context.strokeStyle = context.fillStyle = TRACK_COLOUR;
        if (Math.hypot(ex - px, ey - py) >= 2) {
          context.beginPath();
          context.moveTo(px, py);
          context.lineTo(ex, ey);
          const angle = Math.atan2(ey - py, ex - px);
          const head = Math.min(10, 0.3 * Math.hypot(ex - px, ey - py) + 4);
          context.lineTo(ex - head * Math.cos(angle - 0.45), ey - head * Math.sin(angle - 0.45));
          context.moveTo(ex, ey);
          context.lineTo(ex - head * Math.cos(angle + 0.45), ey - head * Math.sin(angle + 0.45));
          context.stroke();
        }
        context.beginPath();
        context.arc(px, py, 5, 0, 2 * Math.PI);
        context.fill();
        label(context, String(t.id), px + 8, py - 8, TRACK_COLOUR);
      }
    }
    drawScaleBar(context, d);
  }

  // A metre scale as `occmap view` draws it: the largest of 10 cm, 20 cm, 1 m, 2 m, 10 m … that
  // fits in a quarter of the map's width, at the bottom left.
  function drawScaleBar(context, d) {
    const widthM = d.width * d.cellSize;
    let barM = Math.pow(10, Math.floor(Math.log10(widthM / 4)));
    if (2 * barM <= widthM / 4) barM *= 2;
    const barPx = (barM / d.cellSize) * d.scale;
    const x = 10;
    const y = d.height * d.scale - 12;
    for (const [colour, width] of [['#fff', 5], ['#c80000', 2]]) {
      context.beginPath();
      context.moveTo(x, y);
      context.lineTo(x + barPx, y);
      context.strokeStyle = colour;
      context.lineWidth = width;
      context.stroke();
    }
    label(context, barM >= 1 ? barM + ' m' : Math.round(barM * 100) + ' cm', x, y - 6, '#c80000');
  }

  // ---- zones, tracks, daemons as tables ---------------------------------------------------

  function renderLists() {
    const zones = page.zones && Array.isArray(page.zones.zones) ? page.zones.zones : [];
    const zoneRows = zones.map((z) => {
      const tr = row([z.name, { text: z.state_name, className: 'zone-' + z.state_name },
        duration(z.state_s), num(count(z.occupied_cells) + ' of ' + count(z.cells))]);
      tr.dataset.zone = z.name;
      tr.dataset.state = z.state_name;
      return tr;
    });
    $('zones').tBodies[0].replaceChildren(...zoneRows);
    $('zones-none').hidden = zoneRows.length > 0;
    const tracks = page.tracks && Array.isArray(page.tracks.tracks) ? page.tracks.tracks : [];
    const trackRows = tracks.map((t) => row([
      num('#' + t.id), num(fixed(t.x_m, 2) + ', ' + fixed(t.y_m, 2)),
      num(fixed(Math.hypot(t.vx_m_s, t.vy_m_s), 1) + ' m/s'), num(duration(t.age_s)),
    ]));
    $('tracks').tBodies[0].replaceChildren(...trackRows);
    $('tracks-none').hidden = trackRows.length > 0;
  }

  // Why a camera is not simply streaming: down (and its last error), degraded (its light's model
  // explains no view: left out of the maps), moved (knocked or turned).
  function cameraCondition(status, camera) {
    const notes = [];
    let degraded = false;
    const lit = (status.lighting_camera_name || []).indexOf(camera.name);
    if (lit >= 0 && Array.isArray(status.lighting_explained) && status.lighting_explained[lit] === false) {
      degraded = true;
      notes.push('degraded: no change of light explains its view (covered, bumped, lights out, ' +
          'a crowd): left out of the maps, its cells unseen');
    }
    const viewed = (status.view_camera_name || []).indexOf(camera.name);
    if (viewed >= 0 && Array.isArray(status.view_name) && status.view_name[viewed] === 'moved') {
      degraded = true;
      notes.push('moved: turned ' + fixed((status.view_turn_deg || [])[viewed], 1) +
          '° on its mount (re-posed once still, or calibrate it again)');
    }
    if (camera.state_name === 'down') {
      notes.unshift('down' + (camera.last_error ? ': ' + camera.last_error : ': no frames'));
    } else if (camera.state_name === 'starting') {
      notes.unshift('starting: no frame yet');
    }
    return { degraded, text: notes.join('; ') };
  }

  function cameraPcCard(entry, status) {
    const card = element('div', null, 'daemon');
    const silent = entry.heard_s_ago > SILENT_DAEMON_S;
    if (silent) card.classList.add('silent');
    card.dataset.host = status.hostname;
    card.appendChild(element('h3', 'occmapd on ' + status.hostname + ' (' + status.config_file + ')'));
    const facts = element('p', null, 'facts');
    facts.append(
        element('span', status.state_name, status.state_name === 'running' ? 'good' : 'warn'),
        ' · up ' + duration(status.uptime_s) + ' · maps ' + count(status.maps_published) + ' (' +
        fixed(status.maps_per_s, 1) + '/s) · publish errors ' + count(status.publish_errors) +
        ' · fusion p50 ' + fixed(status.fusion_p50_ms, 2) + ' ms, p99 ' +
        fixed(status.fusion_p99_ms, 2) + ' ms');
    if (silent) facts.append(' · ', element('span', 'not heard for ' + duration(entry.heard_s_ago), 'bad'));
    card.appendChild(facts);
    const table = element('table');
    table.createTHead().appendChild(headRow(
        ['camera', 'state', 'fps', 'frames in', 'dropped', 'condition', 'last error']));
    const body = table.createTBody();
    (status.cameras || []).forEach((camera) => {
      const condition = cameraCondition(status, camera);
      const shown = camera.state_name === 'streaming' && condition.degraded ? 'degraded' : camera.state_name;
      const tr = row([
        camera.name,
        { text: shown, className: 'state-' + shown },
        num(fixed(camera.fps, 1)),
        num(count(camera.frames_in)),
        num(count(camera.frames_dropped)),
        condition.text,
        { text: camera.last_error || '', className: 'error' },
      ]);
      tr.dataset.host = status.hostname;
      tr.dataset.camera = camera.name;
      tr.dataset.state = camera.state_name;
      tr.dataset.degraded = condition.degraded ? 'yes' : 'no';
      body.appendChild(tr);
    });
    card.appendChild(table);
    return card;
  }

  function mergeNodeCard(entry, status) {
    const card = element('div', null, 'daemon');
    const silent = entry.heard_s_ago > SILENT_DAEMON_S;
    if (silent) card.classList.add('silent');
    card.dataset.host = status.hostname;
    card.appendChild(element('h3', 'merge node on ' + status.hostname + ' (' + status.config_file + ')'));
    const inputs = status.inputs || [];
    const fresh = inputs.filter((i) => i.state_name === 'fresh').length;
    const facts = element('p', null, 'facts');
    facts.append(
        element('span', status.state_name, status.state_name === 'running' ? 'good' : 'warn'),
        ' · up ' + duration(status.uptime_s) + ' · merged maps ' + count(status.maps_published) +
        ' (' + fixed(status.maps_per_s, 1) + '/s) on ' + status.map_channel + ' · ' + fresh +
        ' of ' + inputs.length + ' inputs fresh · latency p50 ' + fixed(status.latency_p50_ms, 1) +
        ' ms, p99 ' + fixed(status.latency_p99_ms, 1) + ' ms');
    if (silent) facts.append(' · ', element('span', 'not heard for ' + duration(entry.heard_s_ago), 'bad'));
    card.appendChild(facts);
    const table = element('table');
    table.createTHead().appendChild(headRow(
        ['input', 'channel', 'state', 'maps/s', 'behind', 'lost', 'clock', 'last error']));
    const body = table.createTBody();
    for (const input of inputs) {
      const tr = row([
        input.name, input.channel, { text: input.state_name, className: 'state-' + input.state_name },
        num(fixed(input.maps_per_s, 1)), num(fixed(input.age_ms, 0) + ' ms'),
        num(count(input.lost_maps)), num(fixed(input.clock_offset_ms, 1) + ' ms'),
        { text: input.last_error || '', className: 'error' },
      ]);
      tr.dataset.host = status.hostname;
      tr.dataset.input = input.name;
      tr.dataset.state = input.state_name;
      body.appendChild(tr);
    }
    card.appendChild(table);
    return card;
  }

  function renderDaemons() {
    const cards = [];
    const cameras = [];
    for (const entry of page.daemons) {
      const status = entry && entry.status;
      if (!status || typeof status !== 'object') continue;
      if (Array.isArray(status.inputs)) {
        cards.push(mergeNodeCard(entry, status));
      } else {
        cards.push(cameraPcCard(entry, status));
        for (const camera of status.cameras || []) cameras.push([status.hostname, camera.name]);
      }
    }
    if (!cards.length) cards.push(element('p', 'no daemon heard: is occmapd running on this bus?', 'quiet'));
    $('daemons').replaceChildren(...cards);
    renderCameraCards(cameras);
  }

  // A camera's pictures on this server (names percent-encoded: the server decodes and checks them).
  const cameraUrl = (host, name, what) =>
    '/camera/' + encodeURIComponent(host) + '/' + encodeURIComponent(name) + what;

  // A card per camera: its picture, the pixels it finds changed over it in red (both fetched again
  // when a newer preview comes), and, under the pointer, the cells it decides drawn on the map.
  function renderCameraCards(cameras) {
    const key = JSON.stringify(cameras);
    if (key === page.cameraCards) return;
    page.cameraCards = key;
    const cards = cameras.map(([host, name]) => {
      const card = element('div', null, 'camera-card');
      card.dataset.host = host;
      card.dataset.camera = name;
      const view = element('div', null, 'view');
      const picture = element('img', null, 'frame');
      picture.alt = 'camera ' + name + ' on ' + host;
      const changed = element('img', null, 'changed');
      changed.alt = '';
      picture.addEventListener('load', () => {
        view.dataset.loaded = 'yes';
        card.dataset.preview = 'yes';
      });
      view.append(picture, changed);
      card.append(element('div', name, 'name'), element('div', host, 'quiet'), view,
          element('p', 'no preview yet', 'quiet no-preview'));
      card.addEventListener('mouseenter', () => highlight(host, name));
      card.addEventListener('mouseleave', () => highlight(null, null));
      return card;
    });
    if (!cards.length) cards.push(element('p', 'no camera heard yet', 'quiet'));
    $('camera-views').replaceChildren(...cards);
    page.previewsDirty = true;
  }

  // Each card's pictures fetched again when its camera's preview is newer than the one shown.
  function renderPreviews() {
    for (const card of $('camera-views').querySelectorAll('.camera-card')) {
      const preview = page.previews.get(card.dataset.host + '\n' + card.dataset.camera);
      if (!preview || String(preview.utime) === card.dataset.previewUtime) continue;
      card.dataset.previewUtime = String(preview.utime);
      const query = '?u=' + encodeURIComponent(String(preview.utime));
      card.querySelector('img.frame').src = cameraUrl(card.dataset.host, card.dataset.camera, '.jpg') + query;
      card.querySelector('img.changed').src =
          cameraUrl(card.dataset.host, card.dataset.camera, '/changed.png') + query;
    }
  }

  // The cells a camera decides, over the map (a map-sized picture, +y up as the map), or none.
  function highlight(host, name) {
    const cells = $('cells');
    for (const card of $('camera-views').querySelectorAll('.camera-card')) {
      if (card.dataset.host === host && card.dataset.camera === name) {
        card.dataset.highlighted = 'yes';
      } else {
        delete card.dataset.highlighted;
      }
    }
    if (host === null) {
      page.highlighted = null;
      cells.hidden = true;
      delete document.body.dataset.highlighted;
      return;
    }
    page.highlighted = [host, name];
    document.body.dataset.highlighted = host + '/' + name;
    cells.onload = () => {
      if (page.highlighted && page.highlighted[0] === host && page.highlighted[1] === name) {
        cells.hidden = false;
      }
    };
    cells.src = cameraUrl(host, name, '/cells.png');
  }

  // The coverage picture over the map while the switch is on, fetched again every few seconds.
  let coverageTimer = 0;
  function showCoverage() {
    const coverage = $('coverage');
    clearInterval(coverageTimer);
    if (!$('show-coverage').checked) {
      coverage.hidden = true;
      document.body.dataset.coverage = 'no';
      return;
    }
    document.body.dataset.coverage = 'yes';
    const load = () => { coverage.src = '/coverage.png?t=' + Date.now(); };
    coverage.onload = () => { coverage.hidden = !$('show-coverage').checked; };
    load();
    coverageTimer = setInterval(load, COVERAGE_REFRESH_MS);
  }
  $('show-coverage').addEventListener('change', showCoverage);

  // ---- the frame loop ---------------------------------------------------------------------

  let listsAt = 0;
  function frame(now) {
    requestAnimationFrame(frame);
    if (page.pendingMap) {
      const buffer = page.pendingMap;
      page.pendingMap = null;
      const map = decodeMapFrame(buffer);
      if (map) drawMap(map);
    }
    if (page.overlayDirty) {
      page.overlayDirty = false;
      drawOverlay();
    }
    if (page.daemonsDirty) {
      page.daemonsDirty = false;
      renderDaemons();
    }
    if (page.previewsDirty) {
      page.previewsDirty = false;
      renderPreviews();
    }
    // Tables of zones and tracks a few times a second: text changing at 30 Hz cannot be read.
    if (page.listsDirty && now - listsAt > 250) {
      page.listsDirty = false;
      listsAt = now;
      renderLists();
    }
    while (page.mapTimes.length && page.mapTimes[0] < now - 1000) page.mapTimes.shift();
    const stale = page.lastMapAt > 0 && now - page.lastMapAt > STALE_MAP_MS;
    document.body.dataset.stale = stale ? 'yes' : 'no';
    let info = '';
    if (page.drawn) {
      info = 'map ' + page.drawn.seq + ' · ' + page.mapTimes.length + ' maps/s · ' +
          page.drawn.width + ' × ' + page.drawn.height + ' cells of ' +
          fixed(page.drawn.cellSize * 100, 0) + ' cm';
      if (page.mapsDropped) info += ' · ' + count(page.mapsDropped) + ' skipped by this browser';
    }
    if (stale) info = 'no map for ' + duration((now - page.lastMapAt) / 1000) + ' (is occmapd running?) · ' + info;
    $('map-info').textContent = info;
  }

  // ---- for tests --------------------------------------------------------------------------

  // What is on the map canvas: the seq drawn and the colour at the centre of each cell asked for
  // ([row, column], map rows, row 0 the smallest y), read back from the canvas itself.
  window.occmapProbe = (cells) => {
    const d = page.drawn;
    if (!d) return null;
    const canvas = $('map');
    const pixels = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    const colours = (cells || []).map(([r, c]) => {
      if (r < 0 || c < 0 || r >= d.height || c >= d.width) return null;
      const x = Math.floor((c + 0.5) * d.scale);
      const y = Math.floor((d.height - 1 - r + 0.5) * d.scale);
      const o = (y * canvas.width + x) * 4;
      return [pixels[o], pixels[o + 1], pixels[o + 2]];
    });
    return { seq: d.seq, width: d.width, height: d.height, scale: d.scale,
             received: page.mapsReceived, dropped: page.mapsDropped, colours };
  };

  connect();
  requestAnimationFrame(frame);
})();
