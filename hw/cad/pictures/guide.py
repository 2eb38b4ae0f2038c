"""The build guide (docs/build.md) from its data, hw/build_steps.toml: one numbered section per step
with its parts (quantities from the BOM, hw/bom.csv), tools, picture, what to do and the check.

The steps that carry out an assembly-sequence step or a casting view (``sequence = "..."``) take that
step's picture (whisker.cad.pictures.assembly_images names the files), so the guide, the pictures and the
sequence check (whisker.cad.assembly.sequence) read one list. tests/test_build_guide.py fails when the page,
the data, the pictures, the sequence or the BOM disagree. `make guide` rewrites the page.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

from whisker.design import DesignError
from whisker.files import atomic_write_text, read_toml
from whisker.resources import hw_dir

STEPS = hw_dir() / "build_steps.toml"
BOM = hw_dir() / "bom.csv"
BEGIN, END = "<!-- BEGIN BUILD STEPS (make guide, from hw/build_steps.toml) -->", "<!-- END BUILD STEPS -->"


@dataclass(frozen=True)
class GuideStep:
    id: str
    title: str
    parts: tuple[tuple[str, str], ...]   # (BOM item, quantity: a number or "all")
    tools: tuple[str, ...]
    do: str
    check: str
    picture: str = ""                     # relative to docs/
    sequence: str = ""                    # the assembly-sequence step or casting view it carries out
    command: str = ""


def load(path: str | Path = STEPS) -> tuple[dict[str, str], list[GuideStep]]:
    """(tools by id, steps in order) from the guide's data file."""
    data = read_toml(path, "build steps", DesignError)
    tools = {t["id"]: t["what"] for t in data.get("tool", [])}
    steps = []
    for i, raw in enumerate(data.get("step", [])):
        try:
            steps.append(GuideStep(raw["id"], raw["title"], tuple((str(p), str(q)) for p, q in raw.get("parts", [])),
                                   tuple(raw.get("tools", [])), raw["do"].strip(), raw["check"],
                                   raw.get("picture", ""), raw.get("sequence", ""), raw.get("command", "")))
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise DesignError(f"build steps {path}: step {i + 1} is malformed ({err})") from None
    return tools, steps


def bom_lines(path: str | Path = BOM) -> dict[str, dict[str, str]]:
    with open(path, newline="") as f:
        return {r["item"]: r for r in csv.DictReader(f)}


def sequence_pictures() -> dict[str, str]:
    """Assembly picture (relative to docs/) of every casting view and sequence step, by name."""
    from whisker.cad.pictures import assembly_images

    return {v.name: f"images/assembly/{v.file_name(i)}" for i, v in enumerate(assembly_images.views(), start=1)}


def picture(step: GuideStep, pictures: dict[str, str] | None = None) -> str:
    if step.sequence:
        pictures = sequence_pictures() if pictures is None else pictures
        if step.sequence not in pictures:
            raise DesignError(f"build step {step.id!r}: no assembly step or casting view {step.sequence!r}")
        return pictures[step.sequence]
    return step.picture


def render(tools: dict[str, str], steps: list[GuideStep], bom: dict[str, dict[str, str]], d=None) -> str:
    """The tools list and one section per step, Markdown. The steps' text may name design values as
    ``{d.section.key}`` (Python format fields, e.g. ``{d.bom.coil_lead_length:g}``): they are filled
    from the design `d` (default: hw/sensor.toml), so no number of the design is typed in the guide."""
    from whisker.design import load_design

    d = load_design() if d is None else d

    def fill(text: str) -> str:
        try:
            return text.format(d=d)
        except (AttributeError, KeyError, IndexError, ValueError) as err:
            raise DesignError(f"build steps: cannot fill {text[:40]!r}... from the design ({err})") from None

    pics = sequence_pictures()
    out = ["## Tools", "", "| tool | what |", "| --- | --- |"]
    out += [f"| `{k}` | {fill(v)} |" for k, v in tools.items()]
    for n, s in enumerate(steps, start=1):
        title = fill(s.title)
        out += ["", f"## Step {n}: {title}", ""]
        pic = picture(s, pics)
        out += [f'<a href="{pic}"><img src="{pic}" alt="step {n}: {title}" width="420"></a>', ""]
        if s.parts:
            out += ["**Parts:**", ""]
            for item, q in s.parts:
                row = bom.get(item, {})
                if q == "all":
                    qty = f"{row.get('quantity', '?')} {row.get('unit', '')}".strip()
                else:
                    qty = f"{q} {row.get('unit', '')}".strip()
                    if q != row.get("quantity"):  # a share of the line; the other steps use the rest
                        qty += f" (of the BOM's {row.get('quantity', '?')})"
                out.append(f"- {qty}: {row.get('description', item)} (`{item}`)")
            out.append("")
        out.append("**Tools:** " + (", ".join(f"`{t}`" for t in s.tools) or "none") + ".")
        if s.sequence:
            out += ["", f"**Sequence:** `{s.sequence}` (checked by `whisker cad build`: hw/assembly_sequence.toml)."]
        out += ["", fill(s.do), "", f"**Check:** {fill(s.check)}."]
        if s.command:
            out += ["", f"```bash\n{fill(s.command)}\n```"]
    return "\n".join(out)


def update_page(page: str | Path) -> bool:
    """Rewrite the generated block of `page` (atomically); True if it changed."""
    text = Path(page).read_text()
    head, sep, rest = text.partition(BEGIN)
    _, sep2, tail = rest.partition(END)
    if not (sep and sep2):
        raise DesignError(f"{page}: no {BEGIN} ... {END} block to fill")
    tools, steps = load()
    new = f"{head}{BEGIN}\n{render(tools, steps, bom_lines())}\n{END}{tail}"
    if new != text:
        atomic_write_text(page, new)
    return new != text
