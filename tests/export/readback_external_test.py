#!/usr/bin/env python3
"""`rocklab export` read back by readers rocklab does not link.

Oracle: a log written here, without rocklab: the messages are encoded by
the Python types lcm-gen makes from lcm_types/*.lcm (the wire contract) and
framed by hand in LCM's log format; every field of every rocklab type gets
its own value. The .h5 is read with h5py and the .mat with scipy.io.loadmat
(Debian's python3-h5py and python3-scipy: their own readers, not the HDF5
C library or libmatio that rocklab's writers and tests/export/readback.cpp
use), and every column's name, order, type, value and attributes (the
`units` of each field, from the .lcm comments: ATTRS below) is compared.

Adding an attribute (a comment, an enum's names) or a field: add it to
ATTRS; an attribute or a column the table does not list fails, so nothing
rocklab writes goes unchecked.

Exit 0 pass, 1 fail, 77 skip (h5py or scipy missing; under CI=true that
fails instead, as tests/skip.h's ROCKLAB_SKIP does). Environment:
ROCKLAB_CLI, ROCKLAB_SOURCE_DIR, LCM_GEN, ROCKLAB_SCRATCH (a folder to
write in).
"""

import hashlib
import importlib
import math
import os
import re
import shutil
import struct
import subprocess
import sys


def skip(why):
    if os.environ.get("CI") == "true":
        print(f"CI=true: this test may not skip: {why}")
        sys.exit(1)
    print(f"SKIPPED: {why}")
    sys.exit(77)


try:
    import numpy as np
    import h5py
    import scipy
    import scipy.io
except ImportError as e:
    skip(f"{e} (Debian: python3-h5py python3-scipy; tools/setup.sh installs them for the tests)")

# ---- what rocklab must write: per type, per field, the attributes ----------
# Units as on main (the .lcm comments, docs/export.md). {} = no attribute.


def U(unit):
    return {"units": unit}


N = {}
MODEL_STATE = {"utime": U("us"), "name": N, "model": N, "theta": U("rad"), "theta_dot": U("rad/s"),
               "chi": U("1"), "psi": U("rad"), "energy": U("1"), "impact_count": N, "regime": N,
               "alpha": U("rad"), "p": U("rad/s"), "mu": U("1"), "l": U("1")}
ATTRS = {
    "block_state_t": {"utime": U("us"), "seq": N, "theta": U("rad"), "theta_dot": U("rad/s"),
                      "theta_mirror": U("rad"), "theta_camera": U("rad"), "sliding": U("m"), "jump": U("m"),
                      "twist": U("rad"), "out_of_plane": U("m"), "leds_used": N, "flags": N},
    "comparison_t": {"utime": U("us"), "name": N, "error": U("rad"), "rms_window": U("rad"),
                     "window_s": U("s"), "rms_total": U("rad"), "nrms": U("1"), "peak_error": U("rad"),
                     "impact_timing_error": U("s"), "correlation": U("1"), "valid": N, "samples": N},
    "daq_config_t": {"utime": U("us"), "rig_name": N, "calibration_id": N, "sample_rate_hz": U("Hz"),
                     "num_channels": N, "channel_names": N, "channel_units": N, "channel_sensors": N,
                     "gain": N, "offset": N, "alpha": U("rad"), "p": U("rad/s"), "mu": U("1")},
    "event_t": {"utime": U("us"), "source": N, "kind": N, "value": N, "detail": N},
    "health_t": {"utime": U("us"), "node": N, "state": N, "rate_in_hz": U("Hz"), "rate_out_hz": U("Hz"),
                 "count_in": N, "count_out": N, "dropped": N, "gaps": N, "bad_samples": N, "lag_s": U("s")},
    "model_state_t": dict(MODEL_STATE),
    "model_state2_t": dict(MODEL_STATE, equations=N),
    "raw_frame_t": {"utime": U("us"), "seq": N, "num_channels": N, "values": N},
    "table_state_t": {"utime": U("us"), "seq": N, "displacement": U("m"), "velocity": U("m/s"),
                      "acceleration": U("m/s^2"), "accel_source": N},
}
# The successors (their .lcm: the older type's fields with `seq` after utime,
# event2_t and health2_t also `sender`; the same comments, so the same units;
# seq and sender have none).
ATTRS["comparison2_t"] = dict(ATTRS["comparison_t"], seq=N)
ATTRS["daq_config2_t"] = dict(ATTRS["daq_config_t"], seq=N)
ATTRS["event2_t"] = dict(ATTRS["event_t"], seq=N, sender=N)
ATTRS["health2_t"] = dict(ATTRS["health_t"], seq=N, sender=N)
ATTRS["model_state3_t"] = dict(MODEL_STATE, seq=N, equations=N)
# The per-body types: the single-body type's fields as arrays over nbodies
# (the same comments, so the same units), model_state4_t also its mode.
ATTRS["block_state2_t"] = dict(ATTRS["block_state_t"], nbodies=N)
ATTRS["model_state4_t"] = dict(MODEL_STATE, seq=N, equations=N, nbodies=N, mode=N)
# An assembly's comparison (a new type on a channel of its own): comparison2_t's
# fields with nbodies, the figures per body, and the mode fields.
ATTRS["comparison3_t"] = dict(ATTRS["comparison2_t"], nbodies=N, mode_model=N, mode_measured=N,
                              mode_rest_rad=U("rad"), mode_agreement=U("1"), mode_samples=N)
# The posterior band's types (new types, no older one).
ATTRS["model_band_t"] = {"utime": U("us"), "seq": N, "name": N, "model": N, "draws": N, "members": N,
                         "noise_sigma": U("rad"), "theta_median": U("rad"), "theta_lo95": U("rad"),
                         "theta_lo68": U("rad"), "theta_hi68": U("rad"), "theta_hi95": U("rad"),
                         "impacts_up": N, "impact_up_offset_sum": U("s"), "impact_up_offset_sq_sum": U("s^2"),
                         "impacts_down": N, "impact_down_offset_sum": U("s"),
                         "impact_down_offset_sq_sum": U("s^2")}
ATTRS["band_comparison_t"] = {"utime": U("us"), "seq": N, "name": N, "window_s": U("s"),
                              "coverage95_window": U("1"), "coverage95_total": U("1"),
                              "coverage68_window": U("1"), "coverage68_total": U("1"),
                              "median_error": U("rad"), "width95": U("rad"), "impact_timing_z": U("1"),
                              "impact_time_sd": U("s"), "impact_timing_z_rms": U("1"),
                              "matched_crossings": N, "unmatched_crossings": N, "valid": N, "samples": N,
                              "valid_samples": N}
TIME_ATTRS = U("s")  # the `time` column every table starts with
CHANNEL = {"block_state_t": "RL_THETA", "comparison_t": "RL_COMPARE_x", "daq_config_t": "RL_DAQ_CONFIG",
           "event_t": "RL_EVENT", "health_t": "RL_HEALTH", "model_state_t": "RL_MODEL_old",
           "model_state2_t": "RL_MODEL_x", "raw_frame_t": "RL_RAW", "table_state_t": "RL_TABLE",
           "comparison2_t": "RL_COMPARE_y", "model_state3_t": "RL_MODEL_y",
           "daq_config2_t": "RL_DAQ_CONFIG", "event2_t": "RL_EVENT", "health2_t": "RL_HEALTH",
           "model_band_t": "RL_BAND_x", "band_comparison_t": "RL_COVERAGE_x",
           "block_state2_t": "RL_THETA", "model_state4_t": "RL_MODEL_z",
           "comparison3_t": "RL_COMPAREBODIES_z"}
# The successors come after every older message (a log of nodes upgraded
# mid-run). On RL_DAQ_CONFIG, RL_EVENT, RL_HEALTH and RL_THETA the channel changes
# type, so its second type gets a table of its own, CHANNEL_<type>, and the
# first keeps the channel's name (docs/export.md).
SUCCESSORS = {"comparison2_t", "daq_config2_t", "event2_t", "health2_t", "model_state3_t", "block_state2_t",
              "model_state4_t"}
TABLE = {t: c + "_" + t if t in SUCCESSORS and list(CHANNEL.values()).count(c) > 1 else c
         for t, c in CHANNEL.items()}
TYPE_OF = {table: type_name for type_name, table in TABLE.items()}
CHANNEL_OF = {table: CHANNEL[type_name] for type_name, table in TABLE.items()}
# Each table's group attributes besides `columns` (checked on its own):
# `channel` and `lcm_type` ("rocklab." + the type) are filled in per table.
GROUP_ATTRS = {}
ROWS = 3
ARRAY_LEN = 2

failures = []
checked = {"h5": 0, "mat": 0}  # values compared, per format


def fail(msg):
    failures.append(msg)
    print("FAIL: " + msg)


# Code fields and the prefix of their constants in the .lcm (kind: the
# constants without a prefix); each column says what its codes mean.
CODE_PREFIX = {"flags": "FLAG_", "accel_source": "ACCEL_", "regime": "REGIME_", "equations": "EQUATIONS_",
               "kind": ""}
CONST = re.compile(r"^\s*const\s+\w+\s+(\w+)\s*=\s*(-?\d+)\s*;")


def code_attrs(path, field):
    """The legend a code column carries, from the .lcm's constants."""
    consts = [(m.group(1), int(m.group(2))) for m in map(CONST.match, open(path)) if m]
    prefix = CODE_PREFIX[field]
    if prefix:
        picked = [(n[len(prefix):], v) for n, v in consts if n.startswith(prefix)]
    else:
        picked = [(n, v) for n, v in consts if not any(n.startswith(q) for q in CODE_PREFIX.values() if q)]
    picked.sort(key=lambda nv: nv[1])
    return {"code_kind": "bitmask" if field == "flags" else "enum", "code_names": [n for n, _ in picked],
            "code_values": [str(v) for _, v in picked]}


# ---- the .lcm files: field names, types, array lengths ---------------------
FIELD = re.compile(r"^\s*(int8_t|int16_t|int32_t|int64_t|double|float|string|boolean)\s+(\w+)\s*(\[\s*(\w+)\s*\])?\s*;")


def lcm_fields(path):
    fields = []
    for line in open(path):
        m = FIELD.match(line)
        if m and not line.lstrip().startswith("const"):
            fields.append((m.group(2), m.group(1), m.group(4)))
    return fields


def value(kind, i, j, k=0):
    """The value of field j (array element k) of message i: distinct everywhere."""
    if kind == "double":
        return math.pi * (i + 1) + j / 7.0 + k / 1000.0
    if kind == "int8_t":
        return (i * 11 + j + k) % 100 - 20
    if kind in ("int16_t", "int32_t"):
        return i * 1000 + j * 10 + k - 3
    if kind == "int64_t":
        return (i * 1000 + j * 10 + k) * 1_000_003 - 7
    if kind == "boolean":
        return (i + j) % 2 == 0
    if kind == "string":
        return f"f{j}-m{i}-e{k}"
    raise ValueError(kind)


def main():
    src = os.environ["ROCKLAB_SOURCE_DIR"]
    cli = os.environ["ROCKLAB_CLI"]
    work = os.path.join(os.environ["ROCKLAB_SCRATCH"], f"export_readback-{os.getpid()}")
    os.makedirs(work)
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, h5py {h5py.__version__}, "
          f"scipy {scipy.__version__}; files in {work}")
    gen = os.path.join(work, "gen")
    subprocess.check_call([os.environ.get("LCM_GEN", "lcm-gen"), "-p", "--ppath", gen] +
                          sorted(os.path.join(src, "lcm_types", f) for f in os.listdir(os.path.join(src, "lcm_types"))
                                 if f.endswith(".lcm")))
    sys.path.insert(0, gen)

    # Every type rocklab publishes is exported, so every .lcm is in the log.
    lcm_types = {f[:-4] for f in os.listdir(os.path.join(src, "lcm_types")) if f.endswith(".lcm")}
    if lcm_types != set(CHANNEL):
        fail(f"types in lcm_types/ {sorted(lcm_types)} are not the types this test writes {sorted(CHANNEL)}")

    # Messages and the expected table of each channel: column -> (kind, values).
    events = []
    expected = {}
    configs = []  # (utime, message) of every daq_config_t and daq_config2_t
    for type_name, channel in CHANNEL.items():
        fields = lcm_fields(os.path.join(src, "lcm_types", type_name + ".lcm"))
        listed = set(ATTRS[type_name])
        in_lcm = [f[0] for f in fields]
        if set(in_lcm) != listed:
            fail(f"{type_name}: fields of the .lcm {in_lcm} are not the fields ATTRS lists {sorted(listed)}")
            continue
        cls = getattr(importlib.import_module(f"rocklab.{type_name}"), type_name)
        columns = {"time": ("double", [], TIME_ATTRS)}
        lcm_path = os.path.join(src, "lcm_types", type_name + ".lcm")
        for name, kind, dim in fields:
            attrs = dict(ATTRS[type_name][name])
            if name in CODE_PREFIX:
                attrs.update(code_attrs(lcm_path, name))
            if dim:
                for k in range(ARRAY_LEN):
                    columns[f"{name}_{k}"] = (kind, [], dict(attrs))
            else:
                columns[name] = (kind, [], attrs)
        for i in range(ROWS):
            msg = cls()
            for j, (name, kind, dim) in enumerate(fields):
                if name == "utime":
                    v = 10_000_000 + 1000 * (i + (ROWS if type_name in SUCCESSORS else 0)) + 17
                elif dim is None and any(f[2] == name for f in fields):
                    v = ARRAY_LEN  # a length field
                elif dim:
                    v = [value(kind, i, j, k) for k in range(ARRAY_LEN)]
                else:
                    v = value(kind, i, j)
                if type_name == "block_state_t" and name == "theta_camera" and i == 1:
                    v = float("nan")  # NaN where a reading is unavailable
                setattr(msg, name, v)
                if dim:
                    for k in range(ARRAY_LEN):
                        columns[f"{name}_{k}"][1].append(v[k])
                else:
                    columns[name][1].append(int(v) if kind == "boolean" else v)
            columns["time"][1].append(msg.utime / 1e6)
            events.append((msg.utime, channel, msg.encode()))
            if type_name.startswith("daq_config"):
                configs.append((msg.utime, msg))
        expected[TABLE[type_name]] = columns
    config = min(configs, key=lambda c: c[0])[1]  # the first in the log: what RL_RAW's columns are named after
    # Events say their kind by name beside the code (the code itself where the
    # .lcm has no such constant).
    for ev in (expected[TABLE["event_t"]], expected[TABLE["event2_t"]]):
        legend = ev["kind"][2]
        names = dict(zip(legend["code_values"], legend["code_names"]))
        ev["kind_name"] = ("string", [names.get(str(v), str(v)) for v in ev["kind"][1]],
                           {"description": "the name of kind's code"})
    # RL_RAW: values_k say which rig channel they are, and a column per channel
    # (named after it) holds the same raw values.
    raw = expected["RL_RAW"]
    for k in range(ARRAY_LEN):
        desc = (f"channel {config.channel_names[k]} (sensor {config.channel_sensors[k]}), raw; physical = "
                f"gain * raw + offset in {config.channel_units[k]}, gain {config.gain[k]!r}, offset "
                f"{config.offset[k]!r} (RL_DAQ_CONFIG, rig {config.rig_name}, calibration {config.calibration_id})")
        raw[f"values_{k}"] = (raw[f"values_{k}"][0], raw[f"values_{k}"][1], {"description": desc})
    for k in range(ARRAY_LEN):
        raw[config.channel_names[k]] = raw[f"values_{k}"]

    # The log, framed as LCM's log format: sync word, event number, stamp,
    # channel and data lengths, channel, data; in utime order.
    events.sort(key=lambda e: e[0])
    log = os.path.join(work, "test.lcm")
    with open(log, "wb") as f:
        for n, (utime, channel, data) in enumerate(events):
            f.write(struct.pack(">IqqII", 0xEDA1DA01, n, utime, len(channel), len(data)))
            f.write(channel.encode())
            f.write(data)

    for ext in ("h5", "mat"):
        out = os.path.join(work, "test." + ext)
        r = subprocess.run([cli, "export", log, "--out", out, "--quiet"], capture_output=True, text=True)
        if r.returncode != 0:
            fail(f"rocklab export --out {out}: exit {r.returncode}: {r.stderr}")
            return
    provenance = expected_provenance(cli, log)
    check_h5(os.path.join(work, "test.h5"), expected, provenance)
    check_mat(os.path.join(work, "test.mat"), expected, provenance)


def expected_provenance(cli, log):
    """What every exported file says made it (docs/provenance.md), with the
    log's size and SHA-256 from hashlib, not rocklab's own hash."""
    version = subprocess.run([cli, "--version"], capture_output=True, text=True, check=True).stdout.split()[1]
    with open(log, "rb") as f:
        data = f.read()
    return {"rocklab_version": version,
            "source_1": f"{log} ({len(data)} bytes, sha256 {hashlib.sha256(data).hexdigest()})"}


def check_provenance(where, got, want, out):
    for key in ("rocklab_version", "build_type", "command", "created_utc", "source_1"):
        if key not in got:
            fail(f"{where}: provenance has no {key!r}: {got}")
    for key, value in want.items():
        if got.get(key) != value:
            fail(f"{where}: provenance {key} is {got.get(key)!r}, want {value!r}")
    if not re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", str(got.get("created_utc"))):
        fail(f"{where}: created_utc {got.get('created_utc')!r} is not ISO 8601 UTC")
    if " export " not in str(got.get("command")) or out not in str(got.get("command")):
        fail(f"{where}: command {got.get('command')!r} is not the export that wrote {out}")
    extra = set(got) - {"rocklab_version", "build_type", "command", "created_utc", "source_1"}
    if extra:
        fail(f"{where}: provenance keys {sorted(extra)} not checked by this test (add them)")


def same(kind, got, want):
    if kind == "string":
        return got == want
    if kind == "double":
        return (math.isnan(want) and math.isnan(got)) or float(got) == want
    return int(got) == int(want)


def text(v):
    if isinstance(v, np.ndarray):
        return [text(x) for x in v.tolist()]
    return v.decode("utf-8") if isinstance(v, bytes) else str(v)


def check_values(where, kind, got, want):
    checked["mat" if ".mat:" in where else "h5"] += len(want)
    if len(got) != len(want):
        fail(f"{where}: {len(got)} rows, want {len(want)}")
        return
    for r, (g, w) in enumerate(zip(got, want)):
        if not same(kind, g, w):
            fail(f"{where}: row {r} is {g!r}, want {w!r}")


def check_h5(path, expected, provenance):
    with h5py.File(path, "r") as f:
        if set(f.keys()) != set(expected):
            fail(f"{path}: groups {sorted(f.keys())}, want {sorted(expected)}")
        check_provenance(f"{path}: file attributes", {k: str(v) for k, v in f.attrs.items()}, provenance, path)
        for channel, columns in expected.items():
            if channel not in f:
                continue
            g = f[channel]
            order = [text(c) for c in g.attrs.get("columns", [])]
            if order != list(columns):
                fail(f"{path}:/{channel}: `columns` attribute {order}, want {list(columns)}")
            want_group = dict(GROUP_ATTRS, channel=CHANNEL_OF[channel], lcm_type="rocklab." + TYPE_OF[channel])
            got_group = {k: text(v) for k, v in g.attrs.items() if k != "columns"}
            if got_group != want_group:
                fail(f"{path}:/{channel}: group attributes {got_group}, want {want_group}")
            if set(g.keys()) != set(columns):
                fail(f"{path}:/{channel}: datasets {sorted(g.keys())}, want {sorted(columns)}")
            for name, (kind, want, attrs) in columns.items():
                if name not in g:
                    continue
                ds = g[name]
                where = f"{path}:/{channel}/{name}"
                if kind == "string":
                    if h5py.check_string_dtype(ds.dtype) is None:
                        fail(f"{where}: dtype {ds.dtype}, want a string")
                        continue
                    got = [text(v) for v in ds.asstr()[()]]
                elif kind in ("double", "float"):
                    if ds.dtype != np.float64:
                        fail(f"{where}: dtype {ds.dtype}, want float64")
                    got = list(ds[()])
                else:
                    if ds.dtype != np.int64:
                        fail(f"{where}: dtype {ds.dtype}, want int64")
                    got = list(ds[()])
                check_values(where, kind, got, want)
                got_attrs = {k: text(v) for k, v in ds.attrs.items()}
                if got_attrs != attrs:
                    fail(f"{where}: attributes {got_attrs}, want {attrs}")


def mat_name(name):
    """A column's name as a MATLAB field: what is not a letter, digit or _ becomes _."""
    return re.sub(r"[^A-Za-z0-9_]", "_", name)


def check_mat_legend(path, legend, expected):
    """rocklab_columns: one row per column of every table, with its unit."""
    if not isinstance(legend, dict) or not {"table", "column", "unit"} <= set(legend):
        fail(f"{path}: rocklab_columns is {type(legend).__name__}, want a struct of table, column, unit, ...")
        return
    rows = {(t.rstrip(), c.rstrip()): u.rstrip()
            for t, c, u in zip(legend["table"], legend["column"], legend["unit"])}
    for channel, columns in expected.items():
        for name, (_kind, _want, attrs) in columns.items():
            unit = rows.get((channel, mat_name(name)), rows.get((channel, name)))
            if unit is None:
                fail(f"{path}: rocklab_columns has no row for {channel}.{name}")
            elif unit != attrs.get("units", ""):
                fail(f"{path}: rocklab_columns says {channel}.{name} is in {unit!r}, want {attrs.get('units', '')!r}")


def check_mat(path, expected, provenance):
    m = scipy.io.loadmat(path, simplify_cells=True)
    names = {k for k in m if not k.startswith("__") and k not in ("rocklab_columns", "rocklab_provenance")}
    check_mat_legend(path, m.get("rocklab_columns"), expected)
    check_provenance(f"{path}: rocklab_provenance", dict(m.get("rocklab_provenance", {})), provenance, path)
    if names != set(expected):
        fail(f"{path}: variables {sorted(names)}, want {sorted(expected)}")
    for channel, columns in expected.items():
        if channel not in m:
            continue
        s = m[channel]
        if not isinstance(s, dict):
            fail(f"{path}: {channel} is a {type(s).__name__}, want a 1x1 struct")
            continue
        if list(s) != [mat_name(c) for c in columns]:
            fail(f"{path}: {channel}'s fields {list(s)}, want {[mat_name(c) for c in columns]}")
        for name, (kind, want, _attrs) in columns.items():
            if mat_name(name) not in s:
                continue
            v = np.atleast_1d(s[mat_name(name)])
            where = f"{path}: {channel}.{name}"
            if kind == "string":
                if v.dtype.kind != "U":
                    fail(f"{where}: dtype {v.dtype}, want char")
                    continue
                got = [x.rstrip() for x in v]  # rows of a char matrix are blank-padded
            elif kind in ("double", "float"):
                if v.dtype != np.float64:
                    fail(f"{where}: dtype {v.dtype}, want double")
                got = list(v)
            else:
                if v.dtype != np.int64:
                    fail(f"{where}: dtype {v.dtype}, want int64")
                got = list(v)
            check_values(where, kind, got, want)


if __name__ == "__main__":
    main()
    if failures:
        print(f"{len(failures)} failure(s)")
        sys.exit(1)
    print(f"every column of every table read back as written: {checked['h5']} values and their units by h5py, "
          f"{checked['mat']} values by scipy.io.loadmat")
