"""What reading a record did to it, told ahead of the fit's own warnings: a header's units set
aside, a description row skipped, glitches mended, a wrapping clock or angle unwrapped,
standstills cut, a torque read in coarse steps.  Each changes what the numbers mean, so the
report says it first."""
from __future__ import annotations

from datetime import datetime, timezone

from bench.containers import TRUNCATED_WARNING
from bench.position_from_velocity import WARNING as POSITION_FROM_VELOCITY
from bench.records import Record
from bench.velocity_column import SET_ASIDE
from bench.slow_stream import HELD, JOINED_CLOCK, READ_BETWEEN, OWN_CLOCK_ROUGH as NOT_PINNED

STANDSTILL_WARNING = ("the joint stood still for longer than a period of its motion ({n} stretches, "
                      "{s:.3g} s): left out of the analysis like gaps (bench.standstill), the "
                      "motion after each scored from the joint's first sliding")
HELD_WARNING = ("the joint held its pose between moves with a steady torque ({n} dwells, {s:.3g} s): "
                "their insides were left out of the fit and the scoring (bench.standstill), where a "
                "held friction creeps below the encoder's resolution")
# Shown beyond ``perfect_model.COARSE_TORQUE`` (5 % of the Coulomb level): steps of 10 % of Fc
# moved the identified Fc by up to 5 %, of 20 % by up to 13 % (reading noise 0.5-3 % of Fc, too
# little to dither them; tuning seeds 1370-1375, 1764-1767); of 1.5-3.5 % by at most 0.7 %
# (1362-1365).
COARSE_TORQUE_WARNING = ("the torque column sits on steps of {step:.3g} {unit}, {share:.2g} % of the "
                         "Coulomb level (a drive's per-mille of its rated torque, an ADC's count): the "
                         "friction levels can be off by up to half a step; record the torque finer "
                         "(more bits, or the current in a smaller unit) to measure them closer")
UNWRAPPED_WARNING = ("the position wraps at a whole turn ({n} times in the record: a single-turn "
                     "encoder, or an angle logged modulo 360 degrees); it was unwrapped before "
                     "the analysis")
GLITCH_WARNING = ("{n} position samples jumped away from their neighbours and back (encoder or "
                  "logger glitches): their positions were interpolated from the samples around them")
BY_NAME_WARNING = ("no column mapping was given: {taken} were taken by their names; map them with "
                   "--columns if another column is meant (a command beside a reading, say)")
PREAMBLE_WARNING = ("{n} line(s) before the table, from {first!r}, were skipped as the export's "
                    "preamble (bench.text_table); check that the header read is the one meant")
FOOTER_WARNING = ("{n} line(s) after the table, from {first!r}, were skipped as the export's "
                  "footer or a last row cut short (bench.text_table)")
TEXT_ROW_WARNING = ("the line under the header holds words, neither numbers nor units: it was "
                    "skipped as a description row")
# a guess, so said: a header's unit in another code page (a degree sign) could read wrong
CODE_PAGE_WARNING = ("the file is not UTF-8 text: it was read as Windows-1252 (a Western "
                     "Windows PC's); check that the header's units read as meant")
EPOCH_WARNING = ("the time column counts {unit} since 1970 (from {start} UTC), as ROS stamps and many "
                 "loggers do: it was read in {unit}; give --time-unit if it counts another unit")
COUNTER_WARNING = ("the time column is a {bits}-bit counter that wraps ({wraps} times in the "
                   "record); it was unwrapped before the analysis")

FILLED_FORWARD_WARNING = "the {what} column changes only every {rows:.3g} rows, at {rate:.4g} Hz: {how}"
HOW = {READ_BETWEEN: ("a slower stream filled forward onto a faster one's rows, "
                      "interpolated between its readings for the analysis"),
       HELD: ("a command the drive held that long (the motion steps with it where it "
              "changes), used as written")}
# a record's columns as a technician names them
WHAT = {"tau": "torque", "q": "position", "qd": "velocity"}
# a merge of two loggers' clocks (bench.slow_stream.reading_times)
OWN_CLOCK = ("; its readings keep a clock of their own, each shown on the first row after it, and "
             "were placed at that clock's instants")
OWN_CLOCK_ROUGH = (" (to within a row: the rows where they show leave that clock room; each stream's "
                   "own times, where the logger has them, place them exactly)")

# streams on rows of their own (bench.joined_streams)
JOINED_WARNING = ("the {what} column {holds}, at {rate:.4g} Hz{empty}: each was placed at its own time "
                  "on the {base} column's rows, {how}")
JOINED_HOLDS = ("holds readings on rows of its own", ", its other cells empty")
# a signal with a time of its own: a MATLAB struct's, or a column's named by NAME@TIME (bench.own_times)
OWN_TIMES_HOLDS = ("has a time vector of its own ({key})", "")
JOINED_HOW = {READ_BETWEEN: "interpolated between its readings for the analysis",
              HELD: "held between them as a command the drive held (the motion steps with it)"}

# a refusal on a record with a slower stream merged onto its rows (bench.slow_stream): the merge
# lost the readings' instants, up to a row each, which the second derivative amplifies; with
# its own scatter of 0.3 of a row a 200 Hz position under a PID loop was refused as "never
# reaches sliding" on the linear stage, while the same readings at their own times were read
# within 0.5 % (tuning seed 1720)
MERGED_REFUSAL = ("; the {what} column is a slower stream ({rate:.4g} Hz) merged onto these rows, "
                  "which lost its readings' own times (up to a row each), enough to hide sliding on "
                  "a fast joint: where the logger has them, keep them (each stream on rows of its "
                  "own, the other cells empty) and each reading is placed at its own time")


# a position of whole numbers with no unit (bench.units.whole_number_position)
COUNTS_WARNING = ("the position column holds whole numbers only ({lo:g} to {hi:g}) and states no "
                  "unit, so it was taken in {si}: if these are encoder counts, give --position-unit "
                  "K*{si} (K: {si} per count, 0.0015339808*rad for 4096 a turn)")


def with_hint(refusal: str, rec: Record, name: str) -> str:
    """A refusal with what the reading suggests: a position that looks like encoder counts
    read as SI first (the likelier cause than the refusal's own), a column from a slower
    stream merged onto the rows without its own times last."""
    if counts := rec.reading.get("whole_number_position"):
        head = f"{name}: "
        body = refusal[len(head):] if refusal.startswith(head) else refusal
        return f"{head}{_counts_warning(rec, counts)}; {body}"
    return refusal + refusal_hint(rec)


def refusal_hint(rec: Record) -> str:
    """What to add to a refusal when a column came from a slower stream merged onto the rows
    without its own times (empty otherwise)."""
    merged = [(c, ff) for c, ff in rec.reading.get("filled_forward", {}).items()
              if ff.get("clock") != JOINED_CLOCK and ff.get("read_as") != HELD]
    return "".join(MERGED_REFUSAL.format(what=WHAT[c], rate=ff["rate_hz"]) for c, ff in merged[:1])


def _counts_warning(rec: Record, counts) -> str:
    si = "m" if str(rec.meta.get("joint_type", "revolute")).lower() == "prismatic" else "rad"
    return COUNTS_WARNING.format(lo=counts[0], hi=counts[1], si=si)


def reading_warnings(rec: Record, fc: float, torque_step: float, held: list = (),
                     velocity_from: str = "q") -> list[str]:
    """The warnings for ``rec``'s reading, first shown first; ``torque_step``: the torque
    reading's step when it is coarse (``perfect_model.torque_step``), else 0; ``held``: the
    held poses left out [(t0, t1)]; ``velocity_from``: where the fit's velocity came from
    (``bench.velocity_column.velocity_source``)."""
    r = rec.reading
    out = []
    if r.get("whole_number_position"):
        out.append(_counts_warning(rec, r["whole_number_position"]))
    if torque_step > 0:
        unit = "N" if str(rec.meta.get("joint_type", "revolute")).lower() == "prismatic" else "N·m"
        out.append(COARSE_TORQUE_WARNING.format(step=torque_step, unit=unit, share=100 * torque_step / abs(fc)))
    still = r.get("resampling", {}).get("standstills_cut")
    if still:
        out.append(STANDSTILL_WARNING.format(n=len(still), s=r["resampling"]["standstill_time"]))
    if held:
        out.append(HELD_WARNING.format(n=len(held), s=sum(b - a for a, b in held)))
    if r.get("turns_unwrapped"):
        out.append(UNWRAPPED_WARNING.format(n=r["turns_unwrapped"]))
    if r.get("epoch_time"):
        start = datetime.fromtimestamp(r["epoch_time"]["start"], timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
        out.append(EPOCH_WARNING.format(unit=r["epoch_time"]["unit"], start=start))
    if r.get("time_counter"):
        out.append(COUNTER_WARNING.format(**r["time_counter"]))
    for col, ff in r.get("filled_forward", {}).items():
        if ff.get("clock") == JOINED_CLOCK:
            key = r.get("own_times", {}).get(col)
            holds, empty = (OWN_TIMES_HOLDS[0].format(key=key), OWN_TIMES_HOLDS[1]) if key else JOINED_HOLDS
            out.append(JOINED_WARNING.format(what=WHAT[col], rate=ff["rate_hz"], holds=holds, empty=empty,
                                             base=WHAT[r["joined_streams"]["rows_of"]],
                                             how=JOINED_HOW[ff["read_as"]]))
            continue
        out.append(FILLED_FORWARD_WARNING.format(
            what=WHAT[col], rows=ff["rows_per_reading"], rate=ff["rate_hz"], how=HOW[ff["read_as"]])
            + (OWN_CLOCK if ff.get("clock", "").startswith("its own") else "")
            + (OWN_CLOCK_ROUGH if ff.get("clock") == NOT_PINNED else ""))
    if r.get("glitches"):
        out.append(GLITCH_WARNING.format(n=r["glitches"]))
    if r.get("columns_by_name"):
        aside = velocity_from.endswith(f"{SET_ASIDE})")     # a velocity in another unit
        unused = aside or bool(r.get("velocity_set_aside"))   # ... or another joint type's
        taken = ", ".join(f"{c!r} as {WHAT.get(role, 'time')}" for role, c in r["columns_by_name"].items()
                          if not (unused and role == "qd"))
        of_joint = f"joint {r['joint']['label']}'s columns " if r.get("joint") else ""
        out.append(BY_NAME_WARNING.format(taken=of_joint + taken))
        if aside:
            out.append(f"the velocity was taken from the position: {velocity_from[3:-1]}")
    if r.get("velocity_set_aside"):          # bench.units.to_si: its unit is another joint type's
        out.append(f"the velocity was taken from the position: {r['velocity_set_aside']}")
    if r.get("preamble_lines"):
        lines = r["preamble_lines"]
        out.append(PREAMBLE_WARNING.format(n=len(lines), first=lines[0][:60]))
    if r.get("footer_lines"):
        lines = r["footer_lines"]
        out.append(FOOTER_WARNING.format(n=len(lines), first=lines[0][:60]))
    if r.get("text_row_skipped"):
        out.append(TEXT_ROW_WARNING)
    if r.get("position_from") == "qd":
        out.append(POSITION_FROM_VELOCITY)
    if r.get("truncated_lines"):
        out.append(TRUNCATED_WARNING.format(how=r["container"], n=r["truncated_lines"]))
    if r.get("encoding") == "windows-1252":
        out.append(CODE_PAGE_WARNING)
    ignored = list(r.get("header_units", {}).get("ignored", {}).items())
    out += [f"the header states the {role} column's unit: {why}" for role, why in reversed(ignored)]
    return out
