#!/usr/bin/python3
"""Independent reference reader for ArduPilot DataFlash (.bin) logs.

Standard library only. Written from the public format description
(ArduPilot libraries/AP_Logger/LogStructure.h), not from any reader in this
repository. Prints a JSON listing of one log (.bin or .bin.gz) to stdout:

  /usr/bin/python3 tests/data/ardupilot/dataflash_listing.py LOG.bin.gz > X.listing.json
  /usr/bin/python3 tests/data/ardupilot/dataflash_listing.py --self-test LOG.bin.gz

Framing rules used here (the C++ reader is compared against these):
  * A message is 0xA3 0x95 <type> <payload>; its whole length (header
    included) is the Length of the FMT that defined <type>.  FMT (type 128)
    has the fixed length 89 and the fixed layout B B n N Z; an FMT record that
    tries to redefine type 128 is listed in "formats" but does not change how
    FMT is framed.
  * A type is "known" once an FMT for it has been read (earlier in the file).
  * At a position that is not a header followed by a known type, one byte is
    skipped and the scan resumes at the next 0xA3 0x95 <known type>.
  * A message that starts with a valid header but does not fit before the end
    of the file is not counted.
  * trailing_bytes = file size - end of the last complete message;
    skipped_bytes = all other bytes not inside a complete message, so
    sum(lengths of complete messages) + skipped_bytes + trailing_bytes == bytes.
  * FMTU, UNIT and MULT are collected over the whole file and resolved at the
    end (last record per type id / unit id / multiplier id wins), so an FMTU
    that appears after data of its type, or before the UNIT/MULT it refers
    to, still applies.  Units/multipliers only label columns; they never
    change decoded values.
  * Values: float32 widened exactly to double; c/C/e/E divided by 100.0;
    L multiplied by 1e-7; strings (n/N/Z) with trailing NULs stripped,
    decoded latin-1; a = list of 32 int16.  Non-finite floats (none occur in
    the committed listings) would be written as the strings "nan", "inf",
    "-inf" so that the output stays strict JSON.
"""
import gzip
import json
import math
import struct
import sys

HEAD1 = 0xA3
HEAD2 = 0x95
HEADER = b'\xa3\x95'
FMT_TYPE = 128
FMT_LENGTH = 89

# format char -> (struct code, size, converter kind)
FORMAT_CHARS = {
    'b': ('b', 1, 'int'),
    'B': ('B', 1, 'int'),
    'h': ('h', 2, 'int'),
    'H': ('H', 2, 'int'),
    'i': ('i', 4, 'int'),
    'I': ('I', 4, 'int'),
    'f': ('f', 4, 'float'),
    'd': ('d', 8, 'float'),
    'n': ('4s', 4, 'str'),
    'N': ('16s', 16, 'str'),
    'Z': ('64s', 64, 'str'),
    'c': ('h', 2, 'cent'),
    'C': ('H', 2, 'cent'),
    'e': ('i', 4, 'cent'),
    'E': ('I', 4, 'cent'),
    'L': ('i', 4, 'latlon'),
    'M': ('B', 1, 'int'),
    'q': ('q', 8, 'int'),
    'Q': ('Q', 8, 'int'),
    'a': ('32h', 64, 'array'),
}

SAMPLE_NAMES = ('ATT', 'RATE', 'IMU', 'RCOU', 'BAT', 'XKF1', 'BARO', 'GPS',
                'MODE', 'POS')


def cstr(raw):
    return raw.rstrip(b'\x00').decode('latin-1')


def convert(kind, v):
    if kind == 'int':
        return v
    if kind == 'float':
        return v
    if kind == 'str':
        return cstr(v)
    if kind == 'cent':
        return v / 100.0
    if kind == 'latlon':
        return v * 1e-7
    raise ValueError(kind)


class Format(object):
    """One message definition (from an FMT record)."""

    def __init__(self, mtype, length, name, fmt, columns):
        self.type = mtype
        self.length = length
        self.name = name
        self.format = fmt
        self.columns = columns
        self.fields = []          # (struct code, size, kind) per format char
        self.unknown_chars = []
        size = 0
        for ch in fmt:
            if ch in FORMAT_CHARS:
                self.fields.append(FORMAT_CHARS[ch])
                size += FORMAT_CHARS[ch][1]
            else:
                self.unknown_chars.append(ch)
                break             # cannot know where later fields are
        self.payload_size = size
        self.time_first = bool(columns) and columns[0] == 'TimeUS'

    def decode(self, data, start):
        """Decode the payload at data[start:]; returns a list of values.

        Decodes as many fields as fit in Length-3 bytes (a mismatch between
        Length and the format is reported by the caller as a warning)."""
        values = []
        off = start
        end = start + self.length - 3
        for code, size, kind in self.fields:
            if off + size > end:
                break
            v = struct.unpack_from('<' + code, data, off)
            if kind == 'array':
                values.append(list(v))
            else:
                values.append(convert(kind, v[0]))
            off += size
        return values


FMT_FORMAT = Format(FMT_TYPE, FMT_LENGTH, 'FMT', 'BBnNZ',
                    ['Type', 'Length', 'Name', 'Format', 'Columns'])


def load(path):
    with open(path, 'rb') as fh:
        head = fh.read(2)
    if head == b'\x1f\x8b':
        with gzip.open(path, 'rb') as fh:
            return fh.read()
    with open(path, 'rb') as fh:
        return fh.read()


def jsonable(v):
    if isinstance(v, float) and not math.isfinite(v):
        return 'nan' if math.isnan(v) else ('inf' if v > 0 else '-inf')
    return v


def parse(data):
    """Walk a DataFlash byte string; returns (listing dict, diagnostics)."""
    n = len(data)
    by_type = {FMT_TYPE: FMT_FORMAT}      # framing definitions, by type id
    formats_by_name = {}                  # last definition per name
    fmtu = {}                             # type id -> (unit ids, mult ids)
    units = {}                            # unit id char -> label
    mults = {}                            # mult id char -> value
    counts = {}
    first_t = {}
    last_t = {}
    params = {}
    param_msgs = 0
    samples = {}
    skipped = 0
    diag = {
        'messages': 0,
        'message_bytes': 0,
        'resyncs': 0,
        'unknown_format_chars': set(),
        'length_mismatch': {},
        'late_fmt': [],             # (name, type, offset of FMT, prior msgs)
        'type_redefined': [],
        'fmtu_after_data': [],
        'fmtu_before_fmt': [],
        'skipped_at_undefined_type': {},   # type id -> occurrences
        'fmt_offsets': [],
    }
    seen_data = set()          # type ids that already had a data message
    pos = 0
    last_end = 0
    while True:
        # Find a frame start: header + known type with length >= 3.
        if pos + 3 <= n and data[pos] == HEAD1 and data[pos + 1] == HEAD2 \
                and data[pos + 2] in by_type:
            pass
        else:
            if pos + 3 > n:
                break
            # not a valid start: skip at least one byte, resync
            diag['resyncs'] += 1
            if data[pos] == HEAD1 and data[pos + 1] == HEAD2:
                t = data[pos + 2]
                d = diag['skipped_at_undefined_type']
                d[t] = d.get(t, 0) + 1
            q = pos + 1
            found = -1
            while True:
                q = data.find(HEADER, q)
                if q < 0 or q + 3 > n:
                    break
                if data[q + 2] in by_type:
                    found = q
                    break
                d = diag['skipped_at_undefined_type']
                d[data[q + 2]] = d.get(data[q + 2], 0) + 1
                q += 1
            if found < 0:
                break
            pos = found
        mtype = data[pos + 2]
        fmt = by_type[mtype]
        if pos + fmt.length > n:
            break                  # cut off by end of file
        # a complete message: the bytes between last_end and pos were skipped
        skipped += pos - last_end
        values = fmt.decode(data, pos + 3)
        name = fmt.name
        counts[name] = counts.get(name, 0) + 1
        diag['messages'] += 1
        diag['message_bytes'] += fmt.length
        if fmt.time_first and values:
            if name not in first_t:
                first_t[name] = values[0]
            last_t[name] = values[0]
        if mtype == FMT_TYPE:
            diag['fmt_offsets'].append(pos)
            ftype, flen, fname, fstr, fcols = values
            cols = fcols.split(',') if fcols else []
            nf = Format(ftype, flen, fname, fstr, cols)
            for ch in nf.unknown_chars:
                diag['unknown_format_chars'].add((fname, ch))
            if not nf.unknown_chars and nf.payload_size + 3 != flen:
                diag['length_mismatch'][fname] = (flen, nf.payload_size + 3)
            if ftype in by_type and ftype != FMT_TYPE:
                old = by_type[ftype]
                if (old.name, old.length, old.format, old.columns) != \
                        (fname, flen, fstr, cols):
                    diag['type_redefined'].append((ftype, old.name, fname))
            if ftype in seen_data:
                diag['late_fmt'].append((fname, ftype, pos))
            formats_by_name[fname] = nf
            if ftype != FMT_TYPE and flen >= 3:
                by_type[ftype] = nf
        else:
            seen_data.add(mtype)
            row = None
            if name in ('FMTU', 'UNIT', 'MULT', 'PARM') or \
                    name in SAMPLE_NAMES:
                row = dict(zip(fmt.columns, values))
            if name == 'FMTU' and row is not None:
                t = row.get('FmtType')
                if t is not None:
                    if t in seen_data:
                        diag['fmtu_after_data'].append(t)
                    if t not in by_type:
                        diag['fmtu_before_fmt'].append(t)
                    fmtu[t] = (row.get('UnitIds', ''), row.get('MultIds', ''))
            elif name == 'UNIT' and row is not None:
                uid = row.get('Id')
                if isinstance(uid, int):
                    uid = chr(uid & 0xFF)
                units[uid] = row.get('Label')
            elif name == 'MULT' and row is not None:
                mid = row.get('Id')
                if isinstance(mid, int):
                    mid = chr(mid & 0xFF)
                mults[mid] = row.get('Mult')
            elif name == 'PARM' and row is not None:
                param_msgs += 1
                params[row.get('Name')] = row.get('Value')
            if name in SAMPLE_NAMES:
                s = samples.setdefault(name, {})
                if 'first' not in s:
                    s['first'] = row
                s['last'] = row
        pos += fmt.length
        last_end = pos
    trailing = n - last_end

    formats_out = {}
    for name, f in formats_by_name.items():
        ncol = len(f.columns)
        if f.type in fmtu:
            uids, mids = fmtu[f.type]
            ulist = []
            mlist = []
            for i in range(ncol):
                u = uids[i] if i < len(uids) else None
                m = mids[i] if i < len(mids) else None
                ulist.append(units.get(u) if u is not None else None)
                mlist.append(mults.get(m) if m is not None else None)
        else:
            ulist = [None] * ncol
            mlist = [None] * ncol
        formats_out[name] = {
            'type': f.type,
            'length': f.length,
            'format': f.format,
            'columns': f.columns,
            'units': ulist,
            'multipliers': [jsonable(m) for m in mlist],
        }

    def clean(row):
        out = {}
        for k, v in row.items():
            out[k] = [jsonable(x) for x in v] if isinstance(v, list) \
                else jsonable(v)
        return out

    listing = {
        'bytes': n,
        'skipped_bytes': skipped,
        'trailing_bytes': trailing,
        'formats': formats_out,
        'counts': counts,
        'first_time_us': first_t,
        'last_time_us': last_t,
        'parameters': dict((k, jsonable(v)) for k, v in params.items()),
        'parameter_messages': param_msgs,
        'samples': dict((k, {'first': clean(v['first']),
                             'last': clean(v['last'])})
                        for k, v in samples.items()),
    }
    return listing, diag


def dumps(listing):
    return json.dumps(listing, sort_keys=True, indent=1, allow_nan=False,
                      ensure_ascii=True) + '\n'


def check_invariant(listing, diag):
    return diag['message_bytes'] + listing['skipped_bytes'] + \
        listing['trailing_bytes'] == listing['bytes']


def self_test(path):
    data = load(path)
    ok = True

    def report(label, cond, detail):
        nonlocal ok
        ok = ok and cond
        print('%-4s %s: %s' % ('ok' if cond else 'FAIL', label, detail))

    base, bdiag = parse(data)
    json.loads(dumps(base))
    total = sum(base['counts'].values())
    report('clean file', check_invariant(base, bdiag),
           'bytes=%d messages=%d skipped=%d trailing=%d FMT=%d PARM=%d'
           % (base['bytes'], total, base['skipped_bytes'],
              base['trailing_bytes'], base['counts'].get('FMT', 0),
              base['parameter_messages']))
    print('     diagnostics: resyncs=%d undefined-type headers=%s '
          'unknown format chars=%s length mismatches=%s'
          % (bdiag['resyncs'], bdiag['skipped_at_undefined_type'] or 'none',
             sorted(bdiag['unknown_format_chars']) or 'none',
             bdiag['length_mismatch'] or 'none'))
    print('     FMT records after data of their type: %d; '
          'type ids redefined: %s; FMTU after data of its type: %d types; '
          'FMTU before its FMT: %d'
          % (len(bdiag['late_fmt']), bdiag['type_redefined'] or 'none',
             len(set(bdiag['fmtu_after_data'])),
             len(bdiag['fmtu_before_fmt'])))
    offs = bdiag['fmt_offsets']
    print('     FMT offsets: first %d, last %d (%d FMT records after byte '
          '100000)' % (offs[0], offs[-1],
                       sum(1 for o in offs if o > 100000)))

    def diff(a, b):
        keys = set(a['counts']) | set(b['counts'])
        return dict((k, b['counts'].get(k, 0) - a['counts'].get(k, 0))
                    for k in sorted(keys)
                    if a['counts'].get(k, 0) != b['counts'].get(k, 0))

    # 1. flip a payload byte in the middle (inside an IMU message if any)
    mid = len(data) // 2
    p = data.find(HEADER, mid)
    d1 = bytearray(data)
    d1[p + 10] ^= 0xFF
    l1, g1 = parse(bytes(d1))
    json.loads(dumps(l1))
    dc = diff(base, l1)
    report('payload byte flipped at %d' % (p + 10),
           check_invariant(l1, g1) and sum(abs(v) for v in dc.values()) <= 2,
           'count changes=%s skipped=%d' % (dc or 'none',
                                            l1['skipped_bytes']))

    # 2. corrupt a header byte in the middle: forces a resync
    d2 = bytearray(data)
    d2[p] ^= 0xFF
    l2, g2 = parse(bytes(d2))
    json.loads(dumps(l2))
    dc = diff(base, l2)
    report('header byte flipped at %d' % p,
           check_invariant(l2, g2) and l2['skipped_bytes'] > 0 and
           sum(abs(v) for v in dc.values()) <= 3,
           'count changes=%s skipped=%d resyncs=%d'
           % (dc or 'none', l2['skipped_bytes'], g2['resyncs']))

    # 3. corrupt the type byte in the middle (random-ish garbage burst)
    d3 = bytearray(data)
    q = data.find(HEADER, mid + 5000)
    for i in range(q, q + 37):
        d3[i] = (d3[i] * 31 + 7) & 0xFF
    l3, g3 = parse(bytes(d3))
    json.loads(dumps(l3))
    dc = diff(base, l3)
    report('37-byte garbage burst at %d' % q,
           check_invariant(l3, g3) and
           sum(abs(v) for v in dc.values()) <= 6,
           'count changes=%s skipped=%d' % (dc or 'none',
                                            l3['skipped_bytes']))

    # 4. truncate mid-message: cut 5 bytes after the start of a late message
    r = data.rfind(HEADER, 0, len(data) - 200)
    cut = data[:r + 5]
    l4, g4 = parse(cut)
    json.loads(dumps(l4))
    dc = diff(base, l4)
    report('truncated to %d bytes (mid-message)' % len(cut),
           check_invariant(l4, g4) and l4['trailing_bytes'] > 0 and
           all(v <= 0 for v in dc.values()),
           'trailing=%d count changes=%s' % (l4['trailing_bytes'],
                                             dc or 'none'))

    # 5. synthetic log: FMTU after data, UNIT/MULT after FMTU, FMT redefined
    def fmt_rec(t, ln, name, f, cols):
        return bytes([HEAD1, HEAD2, FMT_TYPE, t, ln]) + \
            name.encode().ljust(4, b'\0') + f.encode().ljust(16, b'\0') + \
            cols.encode().ljust(64, b'\0')
    syn = bytearray()
    syn += fmt_rec(128, 89, 'FMT', 'BBnNZ', 'Type,Length,Name,Format,Columns')
    syn += fmt_rec(200, 3 + 8 + 2 + 4 + 4, 'TST', 'QcLf', 'TimeUS,A,Lat,V')
    syn += fmt_rec(201, 3 + 8 + 1 + 16 + 16, 'FMTU', 'QBNN',
                   'TimeUS,FmtType,UnitIds,MultIds')
    syn += fmt_rec(202, 3 + 8 + 1 + 64, 'UNIT', 'QbZ', 'TimeUS,Id,Label')
    syn += fmt_rec(203, 3 + 8 + 1 + 8, 'MULT', 'Qbd', 'TimeUS,Id,Mult')
    syn += b'\x00\x01\x02'                                # 3 junk bytes
    syn += bytes([HEAD1, HEAD2, 200]) + struct.pack('<Qhif', 1000, -1234,
                                                    515000000, 0.1)
    syn += bytes([HEAD1, HEAD2, 99]) + b'\x00' * 5        # undefined type
    syn += bytes([HEAD1, HEAD2, 200]) + struct.pack('<Qhif', 2000, 5, -1, 2.5)
    syn += bytes([HEAD1, HEAD2, 201]) + struct.pack(
        '<QB16s16s', 3000, 200, b's-DU', b'F0GX')
    syn += bytes([HEAD1, HEAD2, 202]) + struct.pack('<Qb64s', 4000, ord('s'),
                                                    b's')
    syn += bytes([HEAD1, HEAD2, 202]) + struct.pack('<Qb64s', 4000, ord('D'),
                                                    b'deglatitude')
    syn += bytes([HEAD1, HEAD2, 203]) + struct.pack('<Qbd', 5000, ord('F'),
                                                    1e-6)
    syn += bytes([HEAD1, HEAD2, 203]) + struct.pack('<Qbd', 5000, ord('G'),
                                                    1e-7)
    syn += bytes([HEAD1, HEAD2, 200]) + b'\x01\x02'       # cut off
    l5, g5 = parse(bytes(syn))
    f = l5['formats']['TST']
    exp_units = ['s', None, 'deglatitude', None]
    exp_mults = [1e-6, None, 1e-7, None]
    cond = (l5['counts'] == {'FMT': 5, 'TST': 2, 'FMTU': 1, 'UNIT': 2,
                             'MULT': 2} and
            f['units'] == exp_units and f['multipliers'] == exp_mults and
            l5['skipped_bytes'] == 3 + 8 and l5['trailing_bytes'] == 5 and
            l5['first_time_us']['TST'] == 1000 and
            l5['last_time_us']['TST'] == 2000 and
            l5['formats']['UNIT']['units'] == [None, None, None] and
            check_invariant(l5, g5))
    report('synthetic log (late FMTU/UNIT/MULT, junk, undefined type, '
           'cut-off end)', cond,
           'units=%s mults=%s skipped=%d trailing=%d'
           % (f['units'], f['multipliers'], l5['skipped_bytes'],
              l5['trailing_bytes']))
    print('self-test %s' % ('PASSED' if ok else 'FAILED'))
    return 0 if ok else 1


def main(argv):
    if len(argv) == 3 and argv[1] == '--self-test':
        return self_test(argv[2])
    if len(argv) != 2:
        sys.stderr.write('usage: %s [--self-test] LOG.bin[.gz]\n' % argv[0])
        return 2
    listing, diag = parse(load(argv[1]))
    for name, (ln, calc) in sorted(diag['length_mismatch'].items()):
        sys.stderr.write('warning: %s Length %d but format gives %d\n'
                         % (name, ln, calc))
    for name, ch in sorted(diag['unknown_format_chars']):
        sys.stderr.write('warning: %s uses unknown format char %r\n'
                         % (name, ch))
    sys.stdout.write(dumps(listing))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
