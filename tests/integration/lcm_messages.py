"""Independent decoders (not our C++ code) of the LCM encodings of ips messages, for the
integration tests: an 8-byte type fingerprint, then the fields in declaration order, big-endian; a
string is an int32 length (with its NUL), the bytes, a NUL; a boolean one byte (LCM type
specification, lcm-proj.github.io/lcm/content/lcm-type-ref.html)."""
import struct


class _Reader:
    def __init__(self, data):
        self.data, self.i = data, 8  # skip the fingerprint

    def take(self, fmt):
        v = struct.unpack_from('>' + fmt, self.data, self.i)[0]
        self.i += struct.calcsize('>' + fmt)
        return v

    def string(self):
        n = self.take('i')
        s = self.data[self.i:self.i + n - 1].decode('utf-8', 'replace')
        self.i += n
        return s


def uwb_range(data):
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), tag_id=r.string(), anchor_id=r.string(),
                range_m=r.take('d'), rx_power_dbm=r.take('f'), fp_power_dbm=r.take('f'),
                quality=r.take('f'), seq=r.take('i'))


def uwb_rx(data):
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), anchor_id=r.string(), sender_id=r.string(),
                is_sync=bool(r.take('b')), seq=r.take('i'), rx_counter=r.take('q'),
                counter_hz=r.take('d'), rx_power_dbm=r.take('f'), fp_power_dbm=r.take('f'),
                quality=r.take('f'))


def health(data):
    r = _Reader(data)
    h = dict(utime=r.take('q'), source=r.string(), host=r.string(), pid=r.take('i'),
             state=r.take('b'), msgs_in=r.take('q'), msgs_out=r.take('q'),
             parse_errors=r.take('q'), drops=r.take('q'), last_error=r.string(),
             uptime_us=r.take('q'), kernel_drops=r.take('q'), queue_drops=r.take('q'),
             seq_lost=r.take('q'), recv_buf_bytes=r.take('i'))
    # consistency (issue 22), version and note (issue 23) came later: absent from older messages.
    for name in ('consistency', 'version', 'note'):
        h[name] = r.string() if r.i < len(r.data) else None
    return h


def baro(data):
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), sensor_id=r.string(),
                pressure_pa=r.take('d'), temperature_c=r.take('d'), humidity_pct=r.take('d'),
                is_reference=bool(r.take('b')), known_height_m=r.take('d'))


def altitude(data):
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), tag_id=r.string(), height_m=r.take('d'),
                height_std_m=r.take('d'), vertical_speed_mps=r.take('d'), floor=r.take('i'),
                floor_valid=bool(r.take('b')))


def pose(data):
    r = _Reader(data)
    p = dict(utime=r.take('q'), source=r.string(), tag_id=r.string(),
             position=[r.take('d') for _ in range(3)])
    r.i += 8 * 9 + 8 * 3 + 8 + 4 + 8  # position_cov, velocity, heading_rad, num_used, residual_m
    p['status'] = r.take('i')
    return p


def zone_event(data):
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), seq=r.take('q'), tag_id=r.string(),
                zone_id=r.string(), zone_name=r.string(), floor=r.take('i'), event=r.take('b'),
                dwell_s=r.take('d'), position=[r.take('d') for _ in range(3)],
                pose_channel=r.string(), alert=bool(r.take('b')))


ZONE_ENTER, ZONE_LEAVE, ZONE_DWELL = 1, 2, 3


def alert(data):
    r = _Reader(data)
    return dict(utime=r.take('q'), source=r.string(), seq=r.take('q'), id=r.take('q'),
                kind=r.take('b'), severity=r.take('b'), state=r.take('b'), subject=r.string(),
                text=r.string())


ALERT_TAG_SILENT, ALERT_PROCESS_DEGRADED, ALERT_PROCESS_GONE, ALERT_ZONE = 1, 2, 3, 4
ALERT_RAISED, ALERT_CLEARED = 1, 2
