"""What ``femcal COMMAND --help`` teaches besides the options: a description for the commands
whose parser gives none, and examples for every command, run from the project's root on the
bundled truck frame (``models/truck_frame``) so that each can be tried as it stands.

:func:`annotate` walks the parser tree once it is built and adds both; the examples are kept
as written (one command per line), the descriptions are wrapped as argparse wraps them.
"""

from __future__ import annotations

import argparse

M = "models/truck_frame"
RIG = f"--actuators {M}/rig_frame.inputs.csv --sensors {M}/rig_frame.sensors.csv"
#: The rig frame's seven actuators (its inputs CSV).
ACTUATORS = ("V_front_left", "V_front_right", "V_rear_left", "V_rear_right", "L_front",
             "L_rear", "X_rear")

#: Descriptions of the commands whose parsers give none (the help line is a summary only).
DESCRIPTIONS: dict[str, str] = {
    "info": "Read a NASTRAN deck (its INCLUDEs too) and summarise it: the cards by type, "
    "grids, degrees of freedom, elements, properties and materials, the case control's "
    "method and constraints. A deck that cannot be read is reported card by card with "
    "file:line; nothing is solved.",
    "solve": "Solve the deck's normal modes (SOL 103; its EIGRL or EIGR, or --modes N) by "
    "shift-invert block Lanczos, and print each mode's frequency. Optionally write the "
    "modes as JSON, a NASTRAN punch file or a UFF 55 file (at the sensors' grids with "
    "--at), pictures (--png), animations (--gif) and a 3-D page (--html).",
    "frf": "Frequency responses of a deck by modal superposition: the modes up to "
    "--modes-to (with --residual, the static part of the others), modal damping --damping, "
    "from each --input force to each --output response, as receptance, mobility or "
    "accelerance, written as an FRF file femcal and other tools read.",
    "synth-test": "Make a synthetic hammer test of a deck: the parameters moved to hidden "
    "values (written to a truth file beside the test), optionally a support and an added "
    "mass the deck lacks, FRFs at the sensors for the inputs with noise, written as UFF 58 "
    "and MATLAB .mat as a lab would hand them over.",
    "model": "Write a bundled model: its NASTRAN deck and the files that go with it "
    "(sensors, inputs, parameters), and with --pictures its views.",
    "timedata info": "Summarise a time-history file (RPC III, CSV or NPZ): its step, length "
    "and, per channel, name, unit, minimum, maximum, mean and RMS.",
    "timedata plot": "Pictures of a time-history file: every channel over time (12 to a "
    "picture; a long record over 5 s around its largest peak, or the first --seconds), "
    "every channel's PSD grouped by unit and, with --inputs and --outputs, coherence and "
    "FRFs. --channels chooses the channels drawn.",
}

#: Examples per command (its words after ``femcal``), each one command line.
EXAMPLES: dict[str, list[str]] = {
    "info": [f"femcal info {M}/hammer_frame.bdf",
             f"femcal info {M}/hammer_frame.bdf --json deck.json"],
    "solve": [f"femcal solve {M}/hammer_frame.bdf --modes 20",
              f"femcal solve {M}/hammer_frame.bdf --modes 20 --out modes/ --html modes.html"],
    "frf": [f"femcal frf {M}/hammer_frame.bdf --input 839:2 --output 39:2 --freq 5:120:0.25 "
            "--damping 0.01 --quantity accelerance --out frf.npz"],
    "synth-test": [f"femcal synth-test {M}/hammer_frame.bdf --params "
                   f"{M}/hammer_frame.params.toml --sensors {M}/hammer_frame.sensors.csv "
                   f"--inputs {M}/hammer_frame.inputs.csv --seed 7 --out my_test/"],
    "synth-rig-test": [f"femcal synth-rig-test {M}/rig_frame.bdf --params "
                       f"{M}/hammer_frame.params.toml {RIG} --out my_rig_test/"],
    "identify": [f"femcal identify {M}/hammer_test.uff --band 5 120 --out identify/"],
    "calibrate": [f"femcal calibrate {M}/hammer_calibration.toml --out out/",
                  f"femcal calibrate {M}/hammer_calibration.toml --out out/ --workers 2"],
    "correlate": [f"femcal correlate {M}/hammer_frame.bdf {M}/hammer_test.uff --sensors "
                  f"{M}/hammer_frame.sensors.csv --band 5 120 --out correlation/"],
    "init": [f"femcal init {M}/hammer_frame.bdf --test {M}/hammer_test.uff --sensors "
             f"{M}/hammer_frame.sensors.csv --inputs {M}/hammer_frame.inputs.csv --out "
             "my_calibration/"],
    "model": ["femcal model truck-frame --variant rig --out frame/ --pictures"],
    "timedata": [f"femcal timedata info {M}/rig_test.rsp"],
    "timedata info": [f"femcal timedata info {M}/rig_test.rsp"],
    "timedata frf": [f"femcal timedata frf {M}/rig_test.rsp --inputs "
                     + " ".join(f"{a}:displacement" for a in ACTUATORS)
                     + " --outputs S_V_front_left:+Z S_L_rear:+Y --period 68 --out "
                     "rig_frf.npz"],
    "timedata plot": [f"femcal timedata plot {M}/rig_test.rsp --seconds 4 --out rig_pictures/"],
    "study": [f"femcal study {M}/cross_member_study.toml --out study/"],
    "rig": [f"femcal rig simulate {M}/rig_frame.bdf {RIG} --drive {M}/rig_test.drv --periodic "
            "--out response.rsp"],
    "rig simulate": [f"femcal rig simulate {M}/rig_frame.bdf {RIG} --drive {M}/rig_test.drv "
                     "--periodic --out response.rsp"],
    "rig iterate": [f"femcal rig iterate {M}/rig_frame.bdf {RIG} --target {M}/rig_test.rsp "
                    "--control S_V_front_left:+Z S_V_front_right:+Z --band 0.5 40 --out "
                    "iteration/"],
    "rig correct": [f"femcal rig correct {M}/rig_frame.bdf {RIG} --target {M}/rig_test.rsp "
                    "--control S_V_front_left:+Z S_V_front_right:+Z --out drive_1.rsp"],
    "rig compare": [f"femcal rig compare --model nominal={M}/rig_frame.bdf --model "
                    f"battery={M}/rig_frame_battery.bdf {RIG} --target {M}/rig_test.rsp "
                    "--control S_V_front_left:+Z S_V_front_right:+Z --out comparison/"],
}  # fmt: skip


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, except that an epilog of examples keeps its lines."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if text.startswith("examples:"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    """Every (command words, parser) under ``parser``, depth first."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield (*path, name), sub
                yield from commands(sub, (*path, name))


def annotate(parser: argparse.ArgumentParser) -> None:
    """Add :data:`DESCRIPTIONS` where a command has none and :data:`EXAMPLES` as each
    command's epilog."""
    for words, sub in commands(parser):
        key = " ".join(words)
        if not sub.description and key in DESCRIPTIONS:
            sub.description = DESCRIPTIONS[key]
        if key in EXAMPLES:
            sub.epilog = "examples:\n" + "".join(f"  {e}\n" for e in EXAMPLES[key])
            sub.formatter_class = HelpFormatter
