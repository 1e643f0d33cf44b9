#!/usr/bin/env python3
"""Print every occupancy map occmapd broadcasts: seq, size, occupied/free/unseen shares, cameras;
and, about once a second, its zones' states and the people it tracks.

A starting point for programs that use occmap's maps, zones and tracks. occmapd publishes each map
whole (map_frame_t, on the map channel) or, with `transport: {tiles: true}`, in tiles (map_tile_t,
on the map channel's name + "_TILES": maps larger than one datagram, where a lost datagram loses
one tile and its cells are shown unseen); this script reads both. Besides the maps it publishes
the zones' states (zones_t, on the map channel's name + "_ZONES", right after each map) and the
people and objects it finds and follows (tracks_t, on its name + "_TRACKS", whenever its detector
is done with a map). It needs the Python classes that `lcm-gen -p` makes from lcmtypes/*.lcm (the
build puts them in build/lcmtypes/python): give that folder with --types, or put it on PYTHONPATH.

Where the maps come from:
  * the network (LCM's UDP multicast, the URL occmapd publishes to). With LCM's own Python module
    (`import lcm`) when it is installed; otherwise with the small receiver below, which speaks LCM's
    UDP multicast protocol itself (Debian has no Python module for LCM);
  * or an lcm-logger log file (--log FILE).

Maps may be raw or zstd-compressed (occmapd's transport.encoding); zstd needs the `zstandard`
module (Debian: python3-zstandard) or the `zstd` module.

Exit codes: 0 at least one map decoded; 1 failed (a file could not be read); 2 bad arguments or the
types not found; 3 no map (none in the log, or none within --timeout).
"""

import argparse
import math
import os
import re
import select
import socket
import struct
import sys
import time
import urllib.parse
from io import BytesIO

DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
ZONE_STATES = ("free", "occupied", "unseen")  # zone_t.FREE, OCCUPIED, UNSEEN
MAX_SIDE = 8192  # the largest map side occmap's decoders accept
MIN_TILE_SIDE, MAX_TILE_SIDE = 16, 247  # the tile sides occmap's decoders accept (map_tile_t)
FREE, OCCUPIED, UNSEEN = 0, 1, 2
ENCODING_RAW, ENCODING_ZSTD = 0, 1


def parse_arguments():
    parser = argparse.ArgumentParser(
        description="Print every occmap map frame: seq, size, occupied/free/unseen shares and the "
        "cameras used.",
        epilog="Examples:\n"
        "  %(prog)s --types build/lcmtypes/python\n"
        "  PYTHONPATH=build/lcmtypes/python %(prog)s --count 100\n"
        "  %(prog)s --types build/lcmtypes/python --log lcmlog-2024-05-01.00\n",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--types", metavar="DIR",
                        help="folder holding the occmap/ package that lcm-gen -p made "
                        "(build/lcmtypes/python); default: found on PYTHONPATH")
    parser.add_argument("--lcm-url", default=os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL,
                        help="LCM URL to listen on (default: $LCM_DEFAULT_URL, else %(default)s)")
    parser.add_argument("--channel", default="OCCMAP_MAP",
                        help="map channel, a regular expression as in LCM (default %(default)s); "
                        "tiled maps are read on its name + _TILES, zones on its name + _ZONES, "
                        "tracks on its name + _TRACKS")
    parser.add_argument("--log", metavar="FILE", help="read this lcm-logger log instead")
    parser.add_argument("--count", type=int, default=0, help="stop after this many maps")
    parser.add_argument("--timeout", type=float, default=0,
                        help="stop after this many seconds without a message (0: wait for ever)")
    parser.add_argument("--every", type=float, default=1.0, metavar="SECONDS",
                        help="print the zones and the tracks at most once every SECONDS of their "
                        "time (and the zones whenever one changes state; default %(default)s, "
                        "0: every message)")
    parser.add_argument("--receiver", choices=["auto", "lcm", "builtin"], default="auto",
                        help="LCM's Python module, this file's own UDP multicast receiver, or the "
                        "first that works (default)")
    arguments = parser.parse_args()
    if arguments.count < 0 or arguments.timeout < 0 or arguments.every < 0:
        parser.error("--count, --timeout and --every must not be negative")
    return arguments


def import_types(types_folder):
    """map_frame_t, zones_t, tracks_t and map_tile_t (None for those the types folder does not
    have)."""
    if types_folder:
        if not os.path.isdir(os.path.join(types_folder, "occmap")):
            print("map_subscriber: --types %s: no occmap/ package there (it is what "
                  "`lcm-gen -p --ppath DIR lcmtypes/*.lcm` makes; the build puts it in "
                  "build/lcmtypes/python)" % types_folder, file=sys.stderr)
            sys.exit(2)
        sys.path.insert(0, os.path.abspath(types_folder))
    try:
        from occmap import map_frame_t
    except ImportError as error:
        print("map_subscriber: cannot import occmap.map_frame_t (%s): give --types "
              "build/lcmtypes/python or put that folder on PYTHONPATH" % error, file=sys.stderr)
        sys.exit(2)
    try:
        from occmap import map_tile_t
    except ImportError:
        print("map_subscriber: these types have no occmap.map_tile_t (made before it): tiled "
              "maps are not shown", file=sys.stderr)
        map_tile_t = None
    try:
        from occmap import tracks_t, zones_t
    except ImportError:
        print("map_subscriber: these types have no occmap.zones_t and tracks_t (made before "
              "them): zones and tracks are not shown", file=sys.stderr)
        return map_frame_t, None, None, map_tile_t
    return map_frame_t, zones_t, tracks_t, map_tile_t


def printable(text):
    """A text from the network as it may go to a terminal: control characters become '?'."""
    return "".join("?" if ord(c) < 0x20 or 0x7F <= ord(c) < 0xA0 else c for c in text)


def zstd_content_size(frame):
    """The content size a zstd frame's header declares (RFC 8878, 3.1.1), or None if it has none.

    Checked before decompressing, so that a frame that lies cannot make us allocate more than the
    map it belongs to."""
    if len(frame) < 5 or frame[:4] != b"\x28\xb5\x2f\xfd":
        raise ValueError("the data is not a zstd frame")
    descriptor = frame[4]
    size_flag, single_segment, dictionary_flag = descriptor >> 6, descriptor >> 5 & 1, descriptor & 3
    at = 5 + (0 if single_segment else 1) + (0, 1, 2, 4)[dictionary_flag]
    field = (1 if single_segment else 0, 2, 4, 8)[size_flag]
    if field == 0:
        return None
    if len(frame) < at + field:
        raise ValueError("the zstd frame header is truncated")
    size = int.from_bytes(frame[at:at + field], "little")
    return size + 256 if field == 2 else size


def zstd_decompressor():
    """A function (data) -> bytes, or None when no zstd module is installed."""
    try:
        import zstandard

        decompressor = zstandard.ZstdDecompressor()
        return decompressor.decompress
    except ImportError:
        pass
    try:
        import zstd

        return zstd.decompress
    except ImportError:
        return None


def cells_of(encoding, data, cells, decompress):
    """The `cells` cell values that map_frame_t or map_tile_t `data` holds in `encoding`, checked
    (ValueError says what is wrong)."""
    if encoding == ENCODING_RAW:
        grid = bytes(data)
    elif encoding == ENCODING_ZSTD:
        if decompress is None:
            raise ValueError("zstd data, and neither the zstandard nor the zstd module is "
                             "installed (Debian: apt install python3-zstandard)")
        data = bytes(data)
        declared = zstd_content_size(data)
        if declared != cells:
            raise ValueError("the zstd frame declares %s bytes, it should hold %d cells" %
                             ("no size" if declared is None else declared, cells))
        try:
            grid = decompress(data)
        except Exception as error:  # each zstd module has its own error type
            raise ValueError("zstd: %s" % error)
    else:
        raise ValueError("unknown encoding %d" % encoding)
    if len(grid) != cells:
        raise ValueError("%d bytes of cells where %d are due" % (len(grid), cells))
    if sum(grid.count(bytes([value])) for value in (FREE, OCCUPIED, UNSEEN)) != cells:
        raise ValueError("cell values other than 0 free, 1 occupied, 2 unseen")
    return grid


def map_dict(message, grid, encoding, size, tiles=0, tiles_missing=0):
    """A map as this script shows it: the header fields of `message` (a map_frame_t or a tile of
    the map), its cells `grid` and their shares."""
    cells = message.width * message.height
    counts = [grid.count(bytes([value])) for value in (FREE, OCCUPIED, UNSEEN)]
    return {
        "seq": message.seq,
        "utime": message.utime,
        "width": message.width,
        "height": message.height,
        "encoding": "raw" if encoding == ENCODING_RAW else "zstd",
        "bytes": size,
        "tiles": tiles,  # 0 for a map sent whole
        "tiles_missing": tiles_missing,  # tiles that never came: their cells are unseen
        "free": counts[FREE] / cells,
        "occupied": counts[OCCUPIED] / cells,
        "unseen": counts[UNSEEN] / cells,
        "cameras": [camera.name for camera in message.cameras],
        "used": [camera.name for camera in message.cameras if camera.used],
        "cells": grid,  # row-major, row 0 = smallest y; grid[r * width + c]
    }


class MapDecoder:
    """map_frame_t bytes -> a dict, checking every size; ValueError says what is wrong."""

    def __init__(self, map_frame_t):
        self.map_frame_t = map_frame_t
        self.decompress = zstd_decompressor()

    def decode(self, data):
        buffer = BytesIO(data)
        try:
            message = self.map_frame_t.decode(buffer)
        except (ValueError, struct.error) as error:
            raise ValueError("not a map_frame_t, or truncated (%s)" % error)
        if len(message.data) != message.data_size or buffer.tell() != len(data):
            raise ValueError("its sizes do not add up to the %d bytes received" % len(data))
        width, height = message.width, message.height
        if not (1 <= width <= MAX_SIDE and 1 <= height <= MAX_SIDE):
            raise ValueError("a map of %d x %d cells" % (width, height))
        grid = cells_of(message.encoding, message.data, width * height, self.decompress)
        return map_dict(message, grid, message.encoding, len(data))


class TileAssembler:
    """map_tile_t bytes -> whole maps, put together as occmap's own MapTileAssembler does.

    A map sent in tiles (occmapd with `transport: {tiles: true}`) comes as map_tile_t messages on
    the map channel's name + "_TILES": the map cut into a grid of tile_side x tile_side tiles,
    numbered row by row, each with the map's header and camera list. take() checks a tile
    (ValueError says what is wrong) and returns the maps it ends, as MapDecoder's dicts: a map is
    given out when all its tiles have come, or when a tile of a newer map comes first; then the
    cells of its missing tiles are unseen (no one vouches for them) and "tiles_missing" says how
    many. Copies of a tile, and tiles of a map already given out or older, are left out."""

    def __init__(self, map_tile_t):
        self.map_tile_t = map_tile_t
        self.decompress = zstd_decompressor()
        self.current = None  # the map in progress
        self.given = None  # (seq, utime) of the map last given out
        self.tiles_lost = 0
        self.stale = 0

    def _decode(self, data):
        """A checked tile: (message, its cells)."""
        buffer = BytesIO(data)
        try:
            m = self.map_tile_t.decode(buffer)
        except (ValueError, struct.error) as error:
            raise ValueError("not a map_tile_t, or truncated (%s)" % error)
        if buffer.tell() != len(data) or len(m.data) != m.data_size or m.num_cameras < 0:
            raise ValueError("its sizes do not add up to the %d bytes received" % len(data))
        if m.encode() != data:
            raise ValueError("encoded again it is not the bytes received")
        width, height, side = m.width, m.height, m.tile_side
        if not (1 <= width <= MAX_SIDE and 1 <= height <= MAX_SIDE):
            raise ValueError("a map of %d x %d cells" % (width, height))
        if not (math.isfinite(m.cell_size_m) and m.cell_size_m > 0 and
                math.isfinite(m.origin_x_m) and math.isfinite(m.origin_y_m)):
            raise ValueError("a cell size or origin that is not a finite number")
        if not MIN_TILE_SIDE <= side <= MAX_TILE_SIDE:
            raise ValueError("tile_side %d is outside %d..%d" % (side, MIN_TILE_SIDE,
                                                                 MAX_TILE_SIDE))
        columns, rows = -(-width // side), -(-height // side)
        if m.tile_count != columns * rows:
            raise ValueError("tile_count %d is not the %d tiles of a %d x %d map in tiles of %d" %
                             (m.tile_count, columns * rows, width, height, side))
        if not 0 <= m.tile_index < m.tile_count:
            raise ValueError("tile_index %d is outside 0..%d" % (m.tile_index, m.tile_count - 1))
        column, row = m.tile_index % columns * side, m.tile_index // columns * side
        place = (column, row, min(side, width - column), min(side, height - row))
        if (m.first_column, m.first_row, m.tile_width, m.tile_height) != place:
            raise ValueError("tile %d is not where its index puts it in the grid" % m.tile_index)
        return m, cells_of(m.encoding, m.data, m.tile_width * m.tile_height, self.decompress)

    @staticmethod
    def _cameras(m):
        return [(c.name, c.state, c.used, c.sequence, c.capture_utime) for c in m.cameras]

    def take(self, data):
        m, grid = self._decode(data)
        key = (m.seq, m.utime)
        given = []
        current = self.current
        if current is not None and key == current["key"]:
            first = current["first"]
            if (m.width, m.height, m.cell_size_m, m.origin_x_m, m.origin_y_m, m.tile_side) != (
                    first.width, first.height, first.cell_size_m, first.origin_x_m,
                    first.origin_y_m, first.tile_side):
                raise ValueError("tile %d of map seq %d gives the map another geometry than its "
                                 "tiles before" % (m.tile_index, m.seq))
            if self._cameras(m) != current["cameras"]:
                raise ValueError("tile %d of map seq %d gives the map another camera list than "
                                 "its tiles before" % (m.tile_index, m.seq))
            if m.tile_index in current["received"]:
                self.stale += 1
                return given
        else:
            reference = current["key"] if current is not None else self.given
            if reference is not None and m.seq <= reference[0] and m.utime <= reference[1]:
                self.stale += 1  # late: its map was given out, or a newer one has begun
                return given
            given += self.flush()
            current = self.current = {
                "key": key, "first": m, "cameras": self._cameras(m), "received": set(),
                "cells": bytearray([UNSEEN]) * (m.width * m.height), "bytes": 0,
                "encoding": ENCODING_RAW}
        cells = current["cells"]
        for r in range(m.tile_height):
            start = (m.first_row + r) * m.width + m.first_column
            cells[start:start + m.tile_width] = grid[r * m.tile_width:(r + 1) * m.tile_width]
        current["received"].add(m.tile_index)
        current["bytes"] += len(data)
        if m.encoding == ENCODING_ZSTD:
            current["encoding"] = ENCODING_ZSTD
        if len(current["received"]) == m.tile_count:
            given += self.flush()
        return given

    def flush(self):
        """The map in progress, given out now with its missing tiles unseen ([] if none)."""
        current, self.current = self.current, None
        if current is None:
            return []
        self.given = current["key"]
        first = current["first"]
        missing = first.tile_count - len(current["received"])
        self.tiles_lost += missing
        return [map_dict(first, bytes(current["cells"]), current["encoding"], current["bytes"],
                         first.tile_count, missing)]


def decode_whole(message_type, data):
    """One whole message of `message_type` (zones_t, tracks_t) from `data`, or ValueError.

    Anyone on the network can publish on these channels, so a message is kept only when it is
    exactly one: every count matches its array, no byte is left over, and encoded again it is the
    very bytes received (so no string was cut short or lacked its NUL)."""
    buffer = BytesIO(data)
    try:
        message = message_type.decode(buffer)
    except (ValueError, struct.error) as error:
        raise ValueError("not a %s, or truncated (%s)" % (message_type.__name__, error))
    if buffer.tell() != len(data):
        raise ValueError("its sizes do not add up to the %d bytes received" % len(data))
    counts = []
    if hasattr(message, "zones"):
        counts.append((message.num_zones, message.zones))
        for zone in message.zones:
            counts += [(zone.num_corners, zone.corner_x_m), (zone.num_corners, zone.corner_y_m)]
    else:
        counts += [(message.num_footprints, message.footprints),
                   (message.num_tracks, message.tracks)]
    if any(count < 0 or count != len(array) for count, array in counts):
        raise ValueError("a count does not match its array")
    if message.encode() != data:
        raise ValueError("encoded again it is not the bytes received")
    return message


def zones_line(zones):
    """zones_t -> 'zones seq S: NAME STATE for T s (...), ...'."""
    parts = []
    for zone in zones.zones:
        state = ZONE_STATES[zone.state] if 0 <= zone.state < 3 else "state %d" % zone.state
        part = "%s %s for %.1f s" % (printable(zone.name), state, zone.state_s)
        if zone.occupied_cells:
            part += " (%d of %d cells occupied)" % (zone.occupied_cells, zone.cells)
        elif zone.unseen_cells:
            part += " (%d of %d cells unseen)" % (zone.unseen_cells, zone.cells)
        parts.append(part)
    return "zones seq %d: %s" % (zones.seq, ", ".join(parts) or "none")


def tracks_line(tracks):
    """tracks_t -> 'tracks seq S: N tracked: #ID at (X, Y) m moving V m/s, ...; F footprints'."""
    people = ", ".join("#%d at (%.2f, %.2f) m moving %.2f m/s" %
                       (track.id, track.x_m, track.y_m, math.hypot(track.vx_m_s, track.vy_m_s))
                       for track in tracks.tracks)
    tracked = "%d tracked: %s" % (len(tracks.tracks), people) if people else "none tracked"
    found = len(tracks.footprints)
    return "tracks seq %d: %s; %d footprint%s" % (tracks.seq, tracked, found,
                                                   "" if found == 1 else "s")


class Every:
    """Whether to print a message of time `utime` (us): the first, then once every `seconds` of
    the messages' own time (a log is shown as it was, whatever the speed it is read at), and
    whenever `key` changes (a zone's state); all of them when `seconds` is 0."""

    def __init__(self, seconds):
        self.period = int(seconds * 1e6)
        self.last_utime = None
        self.last_key = None

    def due(self, utime, key=None):
        if (self.last_utime is None or self.period == 0 or key != self.last_key or
                not self.last_utime <= utime < self.last_utime + self.period):
            self.last_utime, self.last_key = utime, key
            return True
        return False


def read_log(path):
    """(channel, data, utime) of each event of an LCM log file (LCM's format, big-endian)."""
    sync_word = 0xEDA1DA01
    header = struct.Struct(">IqqII")  # sync, event number, utime, channel length, data length
    with open(path, "rb") as log:
        while True:
            start = log.tell()
            raw = log.read(header.size)
            if not raw:
                return
            if len(raw) < header.size:
                print("map_subscriber: %s ends inside an event header" % path, file=sys.stderr)
                return
            sync, _, utime, channel_length, data_length = header.unpack(raw)
            if sync != sync_word:  # damaged: look for the next event, as LCM's reader does
                log.seek(start + 1)
                if not _seek_sync(log, sync_word):
                    return
                continue
            channel = log.read(channel_length)
            data = log.read(data_length)
            if len(channel) != channel_length or len(data) != data_length:
                print("map_subscriber: %s ends inside an event" % path, file=sys.stderr)
                return
            yield channel.decode("utf-8", "replace"), data, utime


def _seek_sync(log, sync_word):
    pattern = struct.pack(">I", sync_word)
    while True:
        position = log.tell()
        block = log.read(1 << 16)
        if len(block) < 4:
            return False
        found = block.find(pattern)
        if found >= 0:
            log.seek(position + found)
            return True
        log.seek(position + len(block) - 3)


class UdpmReceiver:
    """LCM's UDP multicast protocol, receiving side, for when LCM's Python module is missing.

    A message fits one datagram ("LC02": magic, sequence number, channel NUL-terminated, payload)
    or comes in fragments ("LC03": magic, message sequence number, message size, fragment offset,
    fragment number, fragment count; fragment 0 carries the channel before its part of the
    payload). All fields are big-endian. Fragments of one message are put together per sender.
    """

    SHORT, LONG = 0x4C433032, 0x4C433033
    MAX_MESSAGE = 1 << 28  # LCM_MAX_MESSAGE_SIZE

    def __init__(self, url):
        parts = urllib.parse.urlsplit(url)
        if parts.scheme != "udpm":
            raise ValueError("the built-in receiver speaks udpm:// only, not %s" % url)
        self.group = parts.hostname or "239.255.76.67"
        self.port = parts.port or 7667
        options = urllib.parse.parse_qs(parts.query)
        self.socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        # Several LCM programs on one host share the port, as LCM's own sockets do.
        self.socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if "recv_buf_size" in options:
            self.socket.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF,
                                   int(options["recv_buf_size"][0]))
        self.socket.bind(("", self.port))
        membership = struct.pack("4s4s", socket.inet_aton(self.group), socket.inet_aton("0.0.0.0"))
        self.socket.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
        self.partial = {}  # sender -> [message seqno, channel, bytearray, fragments seen, count]

    def receive(self, timeout):
        """The next whole message as (channel, data), or None after `timeout` seconds."""
        end = None if timeout is None else time.monotonic() + timeout
        while True:
            wait = None if end is None else max(0.0, end - time.monotonic())
            if not select.select([self.socket], [], [], wait)[0]:
                return None
            packet, sender = self.socket.recvfrom(65536)
            message = self._take(packet, sender)
            if message is not None:
                return message

    def _take(self, packet, sender):
        if len(packet) < 8:
            return None
        magic = struct.unpack_from(">I", packet)[0]
        if magic == self.SHORT:
            end = packet.find(b"\0", 8)
            if end < 0:
                return None
            return packet[8:end].decode("utf-8", "replace"), packet[end + 1:]
        if magic != self.LONG or len(packet) < 20:
            return None
        seqno, size, offset, number, count = struct.unpack_from(">IIIHH", packet, 4)
        payload = packet[20:]
        channel = None
        if number == 0:
            end = payload.find(b"\0")
            if end < 0:
                return None
            channel, payload = payload[:end].decode("utf-8", "replace"), payload[end + 1:]
        if size > self.MAX_MESSAGE or count == 0 or number >= count or offset + len(payload) > size:
            return None
        entry = self.partial.get(sender)
        if entry is None or entry[0] != seqno or len(entry[2]) != size:
            # A new message from this sender: whatever was missing of the last one is lost.
            entry = [seqno, None, bytearray(size), set(), count]
            self.partial[sender] = entry
        if channel is not None:
            entry[1] = channel
        entry[2][offset:offset + len(payload)] = payload
        entry[3].add(number)
        if len(entry[3]) == entry[4] and entry[1] is not None:
            del self.partial[sender]
            return entry[1], bytes(entry[2])
        return None


def network_messages(url, channels, receiver, timeout):
    """Yields (channel, data) from the network on any of `channels` (regular expressions), each
    message once; None when `timeout` passed without a message."""
    # One expression for them all (LCM puts ^ and $ around it): a message whose channel matches
    # two of them (the map channel OCCMAP_.* and OCCMAP_MAP_ZONES) is still received once.
    either = "(%s)" % "|".join("(%s)" % channel for channel in channels)
    pattern = re.compile(either)
    if receiver in ("auto", "lcm"):
        try:
            import lcm
        except ImportError:
            if receiver == "lcm":
                print("map_subscriber: --receiver lcm: LCM's Python module is not installed",
                      file=sys.stderr)
                sys.exit(2)
        else:
            print("receiver: LCM's Python module", flush=True)
            yield from _lcm_module_messages(lcm, url, either, channels[0], timeout)
            return
    print("receiver: built-in LCM UDP multicast receiver", flush=True)
    try:
        udpm = UdpmReceiver(url)
    except ValueError as error:
        print("map_subscriber: --lcm-url: %s" % error, file=sys.stderr)
        sys.exit(2)
    except OSError as error:
        print("map_subscriber: cannot listen on %s: %s" % (url, error), file=sys.stderr)
        sys.exit(1)
    print("listening for maps on %s at %s" % (channels[0], url), flush=True)
    last = time.monotonic()
    while True:
        wait = None
        if timeout:
            wait = timeout - (time.monotonic() - last)
            if wait <= 0:
                yield None
                last = time.monotonic()
                continue
        message = udpm.receive(wait)
        if message is not None and pattern.fullmatch(message[0]):
            last = time.monotonic()
            yield message


def _lcm_module_messages(lcm, url, channels, map_channel, timeout):
    connection = lcm.LCM(url)
    queue = []
    connection.subscribe(channels, lambda name, data: queue.append((name, data)))
    print("listening for maps on %s at %s" % (map_channel, url), flush=True)
    while True:
        if not queue and connection.handle_timeout(int(1000 * (timeout or 1))) <= 0:
            if timeout:
                yield None
            continue
        while queue:
            yield queue.pop(0)


def main():
    arguments = parse_arguments()
    map_frame_t, zones_t, tracks_t, map_tile_t = import_types(arguments.types)
    decoder = MapDecoder(map_frame_t)
    assembler = TileAssembler(map_tile_t) if map_tile_t is not None else None
    maps = undecodable = other = lost = zones_heard = tracks_heard = 0
    last_seq = None
    # The map channel, and the tiles', zones' and tracks' channels named after it (checked first:
    # a map channel pattern such as OCCMAP_.* matches them too).
    map_pattern = re.compile(arguments.channel)
    tiles_channel, zones_channel, tracks_channel = ("(%s)_%s" % (arguments.channel, suffix)
                                                   for suffix in ("TILES", "ZONES", "TRACKS"))
    tiles_pattern = re.compile(tiles_channel)
    zones_pattern, tracks_pattern = re.compile(zones_channel), re.compile(tracks_channel)
    zones_every, tracks_every = Every(arguments.every), Every(arguments.every)

    def show_other(channel, data):
        """A zones_t or tracks_t: printed when due; False when `channel` is neither's."""
        nonlocal undecodable, zones_heard, tracks_heard
        if zones_t is not None and zones_pattern.fullmatch(channel):
            message_type = zones_t
        elif tracks_t is not None and tracks_pattern.fullmatch(channel):
            message_type = tracks_t
        else:
            return False
        try:
            message = decode_whole(message_type, data)
        except ValueError as error:
            undecodable += 1
            print("undecodable %s (%d bytes): %s" % (message_type.__name__, len(data), error),
                  flush=True)
            return True
        if message_type is zones_t:
            zones_heard += 1
            states = tuple((zone.name, zone.state) for zone in message.zones)
            if zones_every.due(message.utime, states):
                print(zones_line(message), flush=True)
        else:
            tracks_heard += 1
            if tracks_every.due(message.utime):
                print(tracks_line(message), flush=True)
        return True

    def print_map(frame):
        nonlocal maps, lost, last_seq
        maps += 1
        if last_seq is not None and frame["seq"] > last_seq + 1:
            lost += frame["seq"] - last_seq - 1
        last_seq = frame["seq"]
        how = frame["encoding"]
        if frame["tiles"]:
            how += " in %d tiles (%d lost)" % (frame["tiles"], frame["tiles_missing"])
        print("seq %d  %dx%d %s %d bytes  occupied %.2f %%  free %.2f %%  unseen %.2f %%  "
              "cameras used %d of %d: %s" %
              (frame["seq"], frame["width"], frame["height"], how, frame["bytes"],
               100 * frame["occupied"], 100 * frame["free"], 100 * frame["unseen"],
               len(frame["used"]), len(frame["cameras"]),
               printable(",".join(frame["used"])) or "-"),
              flush=True)

    def show(data):
        nonlocal undecodable
        try:
            frame = decoder.decode(data)
        except ValueError as error:
            undecodable += 1
            print("undecodable message (%d bytes): %s" % (len(data), error), flush=True)
            return
        print_map(frame)

    def show_tile(channel, data):
        """A map_tile_t: the maps it ends printed; False when `channel` is not the tiles'."""
        nonlocal undecodable
        if assembler is None or not tiles_pattern.fullmatch(channel):
            return False
        try:
            frames = assembler.take(data)
        except ValueError as error:
            undecodable += 1
            print("undecodable map_tile_t (%d bytes): %s" % (len(data), error), flush=True)
            return True
        for frame in frames:
            print_map(frame)
        return True

    if arguments.log:
        try:
            for channel, data, _ in read_log(arguments.log):
                if show_tile(channel, data) or show_other(channel, data):
                    if arguments.count and maps >= arguments.count:
                        break
                    continue
                if not map_pattern.fullmatch(channel):
                    other += 1
                    continue
                show(data)
                if arguments.count and maps >= arguments.count:
                    break
        except OSError as error:
            print("map_subscriber: cannot read %s: %s" % (arguments.log, error), file=sys.stderr)
            return 1
    else:
        try:
            channels = ([arguments.channel] + ([tiles_channel] if assembler else []) +
                        ([zones_channel, tracks_channel] if zones_t else []))
            for message in network_messages(arguments.lcm_url, channels, arguments.receiver,
                                             arguments.timeout):
                if message is None:
                    print("nothing for %g s" % arguments.timeout, file=sys.stderr)
                    break
                if show_tile(*message) or show_other(*message):
                    if arguments.count and maps >= arguments.count:
                        break
                    continue
                show(message[1])
                if arguments.count and maps >= arguments.count:
                    break
        except KeyboardInterrupt:
            pass
    # A tiled map still waiting for tiles when the stream ended: shown with them unseen.
    if assembler is not None and not (arguments.count and maps >= arguments.count):
        for frame in assembler.flush():
            print_map(frame)
    print("maps %d, lost %d (seq gaps), undecodable %d, other channels %d, zones_t %d, "
          "tracks_t %d, tiles lost %d" %
          (maps, lost, undecodable, other, zones_heard, tracks_heard,
           assembler.tiles_lost if assembler else 0), flush=True)
    return 0 if maps > 0 else 3


if __name__ == "__main__":
    sys.exit(main())
