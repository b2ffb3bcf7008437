"""Sphinx directives that generate rasc's reference pages from the code itself.

Nothing here holds a copy of what it renders: each directive imports or parses the code
on every build, so a page cannot drift from the program.

``rasc-cli``
    Every command of ``rasc`` (or the one named as argument), from the argparse parsers
    that :func:`rasc.cli.build_parser` builds: description, usage and a table of the
    positional arguments and options with their defaults.
``rasc-table``
    A table of the dataclass rows of a module-level tuple, e.g.
    ``rasc.geometry.frames.FRAMES`` (columns: the dataclass fields).
``rasc-study-params``
    The study parameters of :data:`rasc.study.spec.PARAMS` and the spec's top-level keys.
``rasc-formats``
    Every ``rasc-NAME/N`` file format: from the package's format registry
    (``rasc.formats.FORMATS``) where it has one, else found by parsing the sources: where
    its name is declared, which functions write it (a ``"format": ...`` entry of a dict)
    and which read it (a comparison with the name).
``rasc-messages``
    The refusals (``raise InputError(...)`` and the other :class:`rasc.errors.RascError`
    subclasses) or the warnings (strings appended to a list of warnings, or passed to a
    ``warn`` function, returned in a list by a function named ``*warn*``, or printed as a
    ``rasc COMMAND: warning: ...`` line with words of its own) that the
    package words, found by parsing the sources; a part of a message filled in at run
    time is shown as ``{name}`` (``{…}`` for a longer expression).
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import functools
import importlib
import json
import re
import zlib
from collections import defaultdict
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.util.docutils import SphinxDirective

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "rasc"
FORMAT_RE = re.compile(r"^rasc-[a-z0-9-]+/\d+$")


# ------------------------------------------------------------------ node helpers

def _text(value) -> nodes.Node:
    """A cell's content: ``("code", s)`` is an inline literal, anything else plain text."""
    if isinstance(value, tuple) and value and value[0] == "code":
        # a long dotted name may wrap after a dot (a zero-width space), not mid-word
        return nodes.literal(text=re.sub(r"(?<=[A-Za-z_])\.(?=[A-Za-z_])", ".\u200b",
                                         str(value[1])))
    if isinstance(value, list):   # several pieces in one paragraph
        para = nodes.paragraph()
        for i, v in enumerate(value):
            if i:
                para += nodes.Text(", ")
            para += _text(v)
        return para
    return nodes.Text(str(value))


def table(headers: list[str], rows: list[list], widths: list[int] | None = None
          ) -> nodes.table:
    """A docutils table of ``rows`` (cells as accepted by :func:`_text`)."""
    widths = widths or [1] * len(headers)
    tbl = nodes.table(classes=["rasc-generated"])
    group = nodes.tgroup(cols=len(headers))
    tbl += group
    for w in widths:
        group += nodes.colspec(colwidth=w)
    head = nodes.thead()
    group += head
    row = nodes.row()
    for h in headers:
        row += nodes.entry("", nodes.paragraph(text=h))
    head += row
    body = nodes.tbody()
    group += body
    for cells in rows:
        row = nodes.row()
        for c in cells:
            node = _text(c)
            para = node if isinstance(node, nodes.paragraph) else nodes.paragraph("", "", node)
            row += nodes.entry("", para)
        body += row
    return tbl


def section(directive: SphinxDirective, title: str, ident: str) -> nodes.section:
    sec = nodes.section(ids=[nodes.make_id(ident)],
                        names=[nodes.fully_normalize_name(ident)])
    sec += nodes.title(text=title)
    directive.state.document.note_implicit_target(sec, sec)
    return sec


def _import(dotted: str):
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def _toml(value) -> str:
    """A default as a study spec (TOML) writes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def _show(value) -> str:
    if isinstance(value, tuple):
        value = list(value)
    return repr(value)


# ------------------------------------------------------------------ rasc-cli

def _actions(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if not isinstance(a, argparse._HelpAction)]


def _option_row(action: argparse.Action) -> list:
    if action.option_strings:
        names = list(action.option_strings)
        if action.nargs != 0:
            metavar = action.metavar or action.dest.upper()
            if isinstance(metavar, tuple):
                metavar = " ".join(metavar)
            names = [f"{n} {metavar}" for n in names]
        name = [("code", n) for n in names]
    else:
        name = ("code", action.metavar or action.dest)
    default = action.default
    if action.option_strings and default not in (None, False, argparse.SUPPRESS):
        shown = ("code", _show(default) if not isinstance(default, str) else default)
    elif action.required or not action.option_strings:
        shown = "required"
    else:
        shown = ""
    text = (action.help or "").replace("%(default)s", str(action.default))
    text = text.replace("%%", "%")
    if action.choices and not isinstance(action, argparse._SubParsersAction):
        text = f"{text} (one of: {', '.join(map(str, action.choices))})".strip()
    return [name, shown, text]


class CliDirective(SphinxDirective):
    optional_arguments = 1
    has_content = False

    def run(self):
        from rasc.cli import build_parser

        self.env.note_dependency(str(PACKAGE / "cli.py"))
        parser = build_parser()
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        helps = {a.dest: a.help for a in sub._choices_actions}
        wanted = self.arguments[0] if self.arguments else None
        out: list[nodes.Node] = []
        if wanted is None:
            top = nodes.literal_block(text=parser.format_usage().strip())
            out += [nodes.paragraph(text=parser.description or ""), top]
        for name, cmd in sub.choices.items():
            if wanted and name != wanted:
                continue
            module = f"rasc/commands/{name.replace('-', '_')}.py"
            if (ROOT / module).exists():
                self.env.note_dependency(str(ROOT / module))
            sec = section(self, f"rasc {name}", f"rasc-{name}")
            summary = helps.get(name)
            if summary:
                sec += nodes.paragraph(text=summary)
            if cmd.description and cmd.description != summary:
                for para in cmd.description.split("\n\n"):
                    sec += nodes.paragraph(text=" ".join(para.split()))
            sec += nodes.literal_block(text=cmd.format_usage().strip().removeprefix(
                "usage: "), language="text")
            rows = [_option_row(a) for a in _actions(cmd)]
            if rows:
                sec += table(["argument", "default", "meaning"], rows, [3, 2, 6])
            if cmd.epilog:
                sec += nodes.paragraph(text=" ".join(cmd.epilog.split()))
            out.append(sec)
        return out


# ------------------------------------------------------------------ rasc-table

class TableDirective(SphinxDirective):
    required_arguments = 1
    option_spec = {"columns": directives.unchanged, "code": directives.unchanged}

    def run(self):
        rows = _import(self.arguments[0])
        module = self.arguments[0].rpartition(".")[0]
        self.env.note_dependency(str(ROOT / (module.replace(".", "/") + ".py")))
        fields = [f.name for f in dataclasses.fields(rows[0])]
        if "columns" in self.options:
            fields = self.options["columns"].split()
        code = set((self.options.get("code") or fields[0]).split())
        body = [[("code", getattr(r, f)) if f in code else getattr(r, f) for f in fields]
                for r in rows]
        widths = [2 if f in code else (6 if f == "meaning" else 2) for f in fields]
        return [table(fields, body, widths)]


# ------------------------------------------------------------------ rasc-study-params

class StudyParamsDirective(SphinxDirective):
    option_spec = {"top": directives.flag}

    def run(self):
        spec = importlib.import_module("rasc.study.spec")
        self.env.note_dependency(spec.__file__)
        if "top" in self.options:
            rows = [[("code", k), "required" if k in spec.REQUIRED else "optional"]
                    for k in spec.TOP_KEYS]
            return [table(["key", ""], rows, [2, 2])]
        rows = []
        for name, p in spec.PARAMS.items():
            default = getattr(p, "default", None)
            rows.append([("code", name), getattr(p, "kind", ""),
                         "none" if default is None else ("code", _toml(default)),
                         getattr(p, "help", "")])
        return [table(["parameter", "kind", "default", "meaning"], rows, [2, 1, 1, 6])]


# ------------------------------------------------------------------ source scanning

@functools.lru_cache(maxsize=1)
def _sources() -> tuple[tuple[str, Path, ast.Module], ...]:
    """(module name, path, parsed tree) of every module of the package (parsed once per
    build: a Sphinx build is one process)."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts.pop()
        out.append((".".join(parts), path, ast.parse(path.read_text(encoding="utf-8"))))
    return tuple(out)


def _with_parents(tree: ast.AST):
    """Yield (node, enclosing function name or '', parent) for every node."""
    stack = [(tree, "", None)]
    while stack:
        node, func, parent = stack.pop()
        yield node, func, parent
        inner = node.name if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) else func
        if isinstance(node, ast.ClassDef):
            inner = node.name
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and func and \
                not func.endswith(node.name):
            inner = f"{func}.{node.name}"
        for child in reversed(list(ast.iter_child_nodes(node))):
            stack.append((child, inner, node))


def _placeholder(node: ast.AST) -> str:
    """``{name}`` for a name or attribute (what a reader can guess), else ``{…}``."""
    text = ast.unparse(node)
    return "{" + (text if re.fullmatch(r"[A-Za-z_][\w.]*", text) else "…") + "}"


def message_text(node: ast.AST) -> str | None:
    """The literal text of a message expression, run-time parts as ``{name}``."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr):
        parts = []
        for v in node.values:
            if isinstance(v, ast.Constant):
                parts.append(str(v.value))
            elif isinstance(v, ast.FormattedValue):
                parts.append(_placeholder(v.value))
        return "".join(parts)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add | ast.Mod):
        left, right = message_text(node.left), message_text(node.right)
        if left is not None and isinstance(node.op, ast.Mod):
            return left
        if left is not None or right is not None:
            return (left or _placeholder(node.left)) + (right or _placeholder(node.right))
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
            node.func.attr == "format":
        return message_text(node.func.value)
    return None


def error_classes(sources) -> set[str]:
    """Names of RascError and every class in the package derived from it."""
    names = {"RascError"}
    changed = True
    while changed:
        changed = False
        for _, _, tree in sources:
            for node in ast.walk(tree):
                if isinstance(node, ast.ClassDef) and node.name not in names and any(
                        isinstance(b, ast.Name) and b.id in names
                        or isinstance(b, ast.Attribute) and b.attr in names
                        for b in node.bases):
                    names.add(node.name)
                    changed = True
    return names


#: the start of a warning line a command prints (what follows is the message)
_WARNING_LINE = re.compile(r"^rasc [a-z-]+: warning: ")


def collect_exceptions() -> list[tuple[str, str, list[str], str]]:
    """(module, class, bases, first paragraph of its docstring) of RascError and every
    exception class derived from it in the package."""
    sources = _sources()
    names = error_classes(sources)
    out = []
    for module, _, tree in sources:
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef) and node.name in names:
                doc = (ast.get_docstring(node) or "").split("\n\n")[0]
                out.append((module, node.name, [ast.unparse(b) for b in node.bases],
                            " ".join(doc.split())))
    return sorted(out, key=lambda row: (row[0] != "rasc.errors", row[0], row[1]))


def _call_name(node: ast.Call) -> str:
    f = node.func
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""


def collect_messages(kind: str) -> dict[str, list[tuple[int, str, str, str]]]:
    """{module: [(line, function, class or '', text)]} of refusals or warnings."""
    sources = _sources()
    errors = error_classes(sources)
    found: dict[str, list] = defaultdict(list)
    for module, _, tree in sources:
        for node, func, _parent in _with_parents(tree):
            if kind == "refusals" and isinstance(node, ast.Raise) and \
                    isinstance(node.exc, ast.Call) and _call_name(node.exc) in errors:
                args = node.exc.args
                text = message_text(args[0]) if args else None
                if text is None:
                    text = _placeholder(args[0]) if args else ""
                found[module].append((node.lineno, func, _call_name(node.exc), text))
            elif kind == "warnings" and isinstance(node, ast.Return) and \
                    isinstance(node.value, ast.List) and "warn" in func.lower():
                for elt in node.value.elts:         # a function returning its warnings
                    text = message_text(elt)
                    if text is not None:
                        found[module].append((node.lineno, func, "", text))
            elif kind == "warnings" and isinstance(node, ast.Call):
                name = _call_name(node)
                receiver = ast.unparse(node.func.value) if isinstance(
                    node.func, ast.Attribute) else ""
                if name == "append" and ("warn" in receiver or "warn" in func.lower()):
                    arg = node.args[0] if node.args else None
                elif name == "print" and node.args:
                    # a warning line printed directly: "rasc CMD: warning: <words>"
                    text = message_text(node.args[0]) or ""
                    words = _WARNING_LINE.sub("", text, count=1)
                    own = re.findall(r"[A-Za-z]{2,}", re.sub(r"\{[^}]*\}", "", words))
                    if words != text and len(own) >= 2:     # not just "{eye} eye: {w}"
                        found[module].append((node.lineno, func, "", words))
                    continue
                elif name == "warn" and node.args:
                    arg = node.args[-1] if receiver != "warnings" else node.args[0]
                else:
                    continue
                text = message_text(arg) if arg is not None else None
                if text is None:
                    continue      # a message passed on from elsewhere is listed there
                cls = ""
                if name == "warn" and receiver == "warnings":
                    cls = ast.unparse(node.args[1]) if len(node.args) > 1 else "UserWarning"
                    for kw in node.keywords:
                        if kw.arg == "category":
                            cls = ast.unparse(kw.value)
                found[module].append((node.lineno, func, cls, text))
    return {m: sorted(v) for m, v in sorted(found.items())}


class MessagesDirective(SphinxDirective):
    required_arguments = 1     # refusals | warnings

    def run(self):
        kind = self.arguments[0]
        if kind not in ("refusals", "warnings", "exceptions"):
            raise self.error("rasc-messages: expected refusals, warnings or exceptions, got "
                             f"{kind!r}")
        for path in PACKAGE.rglob("*.py"):
            self.env.note_dependency(str(path))
        if kind == "exceptions":
            return [table(["exception", "bases", "meaning"], [
                [("code", f"{module}.{name}"), [("code", b) for b in bases], doc]
                for module, name, bases, doc in collect_exceptions()], [3, 3, 6])]
        found = collect_messages(kind)
        out: list[nodes.Node] = []
        total = sum(len(v) for v in found.values())
        out.append(nodes.paragraph(text=f"{total} {kind[:-1]} sites in {len(found)} modules "
                                        "(collected from the source on every build)."))
        for module, items in found.items():
            sec = section(self, module, f"{kind}-{module}")
            rows = []
            for line, func, cls, text in items:
                where = [("code", func or "(module)"), f"line {line}"]
                rows.append([where, cls, text] if kind == "refusals" else [where, text])
            headers = ["where", "exception", "message"] if kind == "refusals" \
                else ["where", "message"]
            widths = [2, 1, 7] if kind == "refusals" else [2, 8]
            sec += table(headers, rows, widths)
            out.append(sec)
        return out


# ------------------------------------------------------------------ rasc-formats

def collect_formats(sources=None) -> dict[str, dict[str, set[str]]]:
    """{format: {"declared": {...}, "written": {...}, "read": {...}, "named": {...}}}, by
    scanning ``sources`` ((module, path, tree) triples; default: the package)."""
    sources = _sources() if sources is None else sources
    constants: dict[tuple[str, str], str] = {}
    for module, _, tree in sources:
        for node in tree.body:
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) and \
                    isinstance(node.value.value, str) and FORMAT_RE.match(node.value.value):
                for t in node.targets:
                    if isinstance(t, ast.Name):
                        constants[(module, t.id)] = node.value.value
    info: dict[str, dict[str, set[str]]] = defaultdict(lambda: defaultdict(set))
    for (module, name), fmt in constants.items():
        info[fmt]["declared"].add(f"{module}.{name}")
    for module, _, tree in sources:
        visible = {name: fmt for (m, name), fmt in constants.items() if m == module}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                for alias in node.names:
                    fmt = constants.get((node.module, alias.name))
                    if fmt:
                        visible[alias.asname or alias.name] = fmt
        for node, func, parent in _with_parents(tree):
            fmt = None
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                    FORMAT_RE.match(node.value):
                fmt = node.value
            elif isinstance(node, ast.Name) and node.id in visible:
                fmt = visible[node.id]
            elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
                fmt = next((f for (m, n), f in constants.items()
                            if n == node.attr and m.endswith("." + node.value.id)), None)
            if fmt is None or not func:
                continue
            where = f"{module}.{func}"
            if isinstance(parent, ast.Dict) and any(
                    isinstance(k, ast.Constant) and k.value == "format" and v is node
                    for k, v in zip(parent.keys, parent.values, strict=True)):
                info[fmt]["written"].add(where)
            elif isinstance(parent, ast.Compare):
                info[fmt]["read"].add(where)
            else:
                info[fmt]["named"].add(where)
    return {k: info[k] for k in sorted(info)}


def format_rows() -> list[dict]:
    """One dict per file format: ``tag``, ``what``, ``declared``, ``written``, ``read``
    (lists of ``module.name``, relative to ``rasc.``).

    From the format registry, ``rasc.formats.FORMATS`` (tag → an object with ``what``,
    ``reader``, ``writer`` as ``"module:qualified.name"``), when the package has one; else
    by scanning the sources for ``rasc-NAME/N`` strings (:func:`collect_formats`).
    """
    def short(ref: str) -> str:
        return ref.replace(":", ".").removeprefix("rasc.")

    try:
        registry = importlib.import_module("rasc.formats").FORMATS
    except (ImportError, AttributeError):
        registry = None
    if registry:
        names = {id(v): k for k, v in vars(importlib.import_module("rasc.formats")).items()
                 if not k.startswith("_")}
        return [{"tag": tag, "what": getattr(f, "what", ""),
                 "declared": [f"formats.{names[id(f)]}"] if id(f) in names else [],
                 "written": [short(f.writer)] if getattr(f, "writer", "") else [],
                 "read": [short(f.reader)] if getattr(f, "reader", "") else []}
                for tag, f in sorted(registry.items())]
    return [{"tag": tag, "what": "",
             **{key: sorted(w.removeprefix("rasc.") for w in where.get(key, ()))
                for key in ("declared", "written", "read")}}
            for tag, where in collect_formats().items()]


class FormatsDirective(SphinxDirective):
    def run(self):
        for path in PACKAGE.rglob("*.py"):
            self.env.note_dependency(str(path))
        rows = format_rows()
        with_what = any(r["what"] for r in rows)

        def cell(names):
            return [("code", n) for n in names] or "—"

        body = [[("code", r["tag"]), *([r["what"]] if with_what else []),
                 cell(r["declared"]), cell(r["written"]), cell(r["read"])] for r in rows]
        headers = ["format", *(["what it holds"] if with_what else []), "declared as",
                   "written by", "read by"]
        widths = [2, *([4] if with_what else []), 2, 3, 3]
        note = nodes.paragraph(text="Names are relative to the package rasc.")
        return [table(headers, body, widths), note]


# ------------------------------------------------------------------ docstrings

#: ``|x|`` in a docstring is the absolute value or norm of x, never a reST substitution
_BARS = re.compile(r"(?<![`\\|])\|([^|`\s][^|`]*?)\|(?![`|_])")
#: a numpydoc section header (its underline follows)
_UNDERLINE = re.compile(r"^\s*-{3,}\s*$")
#: an entry of the house's plain field lists: ``name : meaning`` or ``a, b : meaning``
_FIELD = re.compile(r"^(\s*)([A-Za-z_][\w.]*(?:, [A-Za-z_][\w.]*)*) : (.*)$")


def plain_field_lists(lines: list[str]) -> list[str]:
    """The house's ``name : meaning`` lines before any numpydoc section, as a bullet list.

    Many docstrings (dataclasses above all) list their fields as ``name : meaning`` lines
    with indented continuation lines, outside a numpydoc section; reST would read the
    continuation as an unexpected indentation. Each such run becomes a bullet list with
    the names as inline literals; numpydoc sections (a header over ``---``) are left as
    they are.
    """
    out: list[str] = []
    base = None                       # indentation of the field run in progress
    for i, line in enumerate(lines):
        if i + 1 < len(lines) and _UNDERLINE.match(lines[i + 1]) and line.strip():
            out.extend(lines[i:])      # numpydoc sections from here on: untouched
            return out
        m = _FIELD.match(line)
        prev_blank = not out or not out[-1].strip()
        if m and (base is not None and len(m.group(1)) == base or
                  base is None and prev_blank):
            base = len(m.group(1))
            names = ", ".join(f"``{n}``" for n in m.group(2).split(", "))
            out.append(f"{m.group(1)}- {names} : {m.group(3)}")
            continue
        if base is not None and line.strip() and len(line) - len(line.lstrip()) > base:
            out.append(" " * (base + 2) + line.strip())     # continuation of the item
            continue
        if base is not None and line.strip():
            out.append("")                                  # end the list cleanly
        base = None
        out.append(line)
    return out


def _escape_bars(lines: list[str]) -> list[str]:
    """``|x|`` → ``\\|x\\|`` outside inline literals and ``::`` literal blocks."""
    out, literal_indent = [], None
    for line in lines:
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None and line.strip() and indent <= literal_indent:
            literal_indent = None
        if literal_indent is None:
            parts = line.split("``")
            line = "``".join(p if k % 2 else _BARS.sub(r"\\|\1\\|", p)
                             for k, p in enumerate(parts))
            if line.rstrip().endswith("::"):
                literal_indent = indent
        out.append(line)
    return out


def _tidy_docstring(app, what, name, obj, options, lines):
    lines[:] = plain_field_lists(_escape_bars(lines))


def _drop_empty_globs(app, docname, source):
    """A globbed toctree entry of the front page (``guide/*``, ``METHOD*``) that matches no
    page yet is left out (Sphinx would warn, and ``make docs`` treats warnings as errors):
    the guide and topic pages are written by several hands, and pages move between
    folders; the site builds before and after each change."""
    if docname != app.config.root_doc:
        return
    srcdir = Path(app.srcdir)
    kept = []
    for line in source[0].splitlines(keepends=True):
        entry = line.strip()
        if "*" in entry and " " not in entry and not any(
                next(srcdir.glob(entry + suffix), None) for suffix in (".md", ".rst")):
            continue
        kept.append(line)
    source[0] = "".join(kept)


def _add_bases(app, what, name, obj, options, lines):
    """A class's bases at the end of its entry, when it has any besides ``object``
    (autodoc's ``show-inheritance`` writes "Bases: object" on every class, or an empty
    "Bases:" when the event removes it). Runs after numpydoc has rendered the sections."""
    if what not in ("class", "exception") or not isinstance(obj, type):
        return
    bases = [b for b in obj.__bases__ if b is not object]
    if not bases:
        return
    names = [f":class:`{b.__qualname__}`" if b.__module__ == "builtins"
             else f":class:`~{b.__module__}.{b.__qualname__}`" for b in bases]
    lines.extend(["", "*Bases:* " + ", ".join(names)])


def setup(app):
    app.connect("autodoc-process-docstring", _add_bases, priority=600)
    app.connect("autodoc-process-docstring", _tidy_docstring, priority=400)
    app.connect("source-read", _drop_empty_globs)
    app.add_directive("rasc-cli", CliDirective)
    app.add_directive("rasc-table", TableDirective)
    app.add_directive("rasc-study-params", StudyParamsDirective)
    app.add_directive("rasc-messages", MessagesDirective)
    app.add_directive("rasc-formats", FormatsDirective)
    # a change to this file re-reads every page (Sphinx compares env_version)
    env_version = zlib.crc32(Path(__file__).read_bytes())
    return {"version": "1", "env_version": env_version, "parallel_read_safe": True,
            "parallel_write_safe": True}
