"""The report's ``input``, ``units`` and ``resampling``: what reading did to the file."""
from __future__ import annotations

from bench.fitting import FitData


def reading_section(r: dict, data: FitData) -> dict:
    """What reading did to the file: format and columns, unit conversions to SI,
    resampling and segments (used: with scored samples)."""
    if not r:
        return {}
    c, mask = data.c, data.mask
    resampling = dict(r.get("resampling", {}))
    if "empty_rows" in r:    # rows with an empty, NaN or infinite cell (bench.readers)
        resampling["empty_rows_dropped"] = r["empty_rows"]
    if "stamps_spread" in r:  # a clock coarser than the samples (bench.coarse_time)
        resampling["timestamps_spread"] = r["stamps_spread"]
    if "filled_forward" in r:  # a slower torque or position stream (bench.slow_stream)
        resampling["filled_forward"] = r["filled_forward"]
    if "joined_streams" in r:  # streams on rows of their own (bench.joined_streams)
        resampling["joined_streams"] = r["joined_streams"]
    if r.get("glitches"):    # position samples off their neighbours (bench.glitches)
        resampling["position_glitches_mended"] = r["glitches"]
    if "segments" in resampling and len(c.segments) == len(resampling["segments"]):
        resampling["segments"] = [dict(s, scored=bool(mask[a:b].any()))
                                  for s, (a, b) in zip(resampling["segments"], c.grid_segments)]
    return {"input": {"format": r.get("format"), "columns": r.get("columns"),
                      "velocity_from": c.velocity_source,
                      **({"window": r["window"]} if "window" in r else {}),
                      **({"turns_unwrapped": r["turns_unwrapped"]} if "turns_unwrapped" in r else {}),
                      **({"time_counter": r["time_counter"]} if "time_counter" in r else {}),
                      **({"own_times": r["own_times"]} if "own_times" in r else {}),
                      **({"joint": r["joint"]["label"]} if "joint" in r else {}),
                      # what the bytes came wrapped in (bench.containers), a position integrated
                      # (bench.position_from_velocity), times from a rate (bench.sample_rate)
                      **{k: r[k] for k in ("container", "member", "encoding", "truncated_lines", "position_from",
                                           "sample_rate", "preamble_lines", "footer_lines", "epoch_time") if k in r}},
            "units": {"si": True, "conversions": r.get("units", {}),
                      **({"from_header": r["header_units"]["taken"]} if r.get("header_units") else {})},
            "resampling": resampling}
