#!/usr/bin/env python3
"""The layering rules of docs/architecture.md, checked against the source tree.

The build declares every layer in build/smseg_modules.json (CMakeLists.txt: smseg_add_module and
smseg_add_tools): a module's name, its folder and the modules it links. A layer may include the public
headers (include/smseg/...) of itself and of the modules below it (the closure of what it links), and
nothing else: no header of a module above it or beside it, no file of another module's src/.

Also the size rules: no folder holds more than 4,000 lines of source files directly inside it (tests
aside), no source file more than 900 lines. And namespaces follow modules: a source file under
features/<module>/ opens only smseg::<module> and namespaces inside it (detail, anonymous, ...); a tool
(features/<module>/tools/) may also have namespaces of its own outside smseg; another smseg namespace
may be opened only to forward-declare a class of it.

Usage: check_layering.py BUILD/smseg_modules.json   exit 0 when every rule holds, 1 with one line per
                                                   breach otherwise
       check_layering.py --self-test               shows that a forbidden include, an oversized file
                                                   and a foreign namespace are caught (exit 0 when
                                                   they are)
"""
import json
import os
import re
import sys
import tempfile
from pathlib import Path

INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')
SOURCE_SUFFIXES = {".cpp", ".hpp", ".h", ".cc", ".in"}
MAX_FOLDER_LINES = 4000
MAX_FILE_LINES = 900


def load_layers(modules_json):
    layers = json.loads(Path(modules_json).read_text())
    return {layer["name"]: layer for layer in layers}


def is_module(layer):
    return layer["kind"] == "module"  # the others are tools (and benchmarks): programs over the modules


def header_owners(layers):
    """'smseg/frontend/stereo.hpp' -> 'frontend', from every module's include/ folder."""
    owners = {}
    for layer in layers.values():
        if not is_module(layer):
            continue
        include = Path(layer["dir"]) / "include"
        for path in include.rglob("*") if include.is_dir() else []:
            if path.is_file():
                owners[path.relative_to(include).as_posix()] = layer["name"]
    return owners


def closure(layers, name, seen=None):
    """The modules a layer may use: those it links, and what they link, down to the bottom."""
    seen = set() if seen is None else seen
    for dep in layers[name]["deps"]:
        if dep not in layers:
            raise SystemExit(f"smseg_modules.json: layer {name} links unknown module {dep}")
        if dep not in seen:
            seen.add(dep)
            closure(layers, dep, seen)
    return seen


def cycles(layers):
    """Modules that can reach themselves through what they link (there must be none)."""
    return sorted(n for n in layers if is_module(layers[n]) and n in closure(layers, n))


def layer_files(layer):
    root = Path(layer["dir"])
    folders = [root / "src", root / "include"] if is_module(layer) else [root]
    for folder in folders:
        if folder.is_dir():
            yield from sorted(p for p in folder.rglob("*") if p.suffix in SOURCE_SUFFIXES and p.is_file())


def include_breaches(layers, source_root):
    owners = header_owners(layers)
    breaches = []
    for name, layer in sorted(layers.items()):
        allowed = closure(layers, name) | ({name} if is_module(layer) else set())
        for path in layer_files(layer):
            for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                match = INCLUDE.match(line)
                if not match:
                    continue
                header = match.group(1)
                where = f"{os.path.relpath(path, source_root)}:{number}"
                if "/src/" in header or header.startswith("../"):
                    breaches.append(f"{where}: {name} includes {header}: another folder's private file")
                elif header.startswith("smseg/"):
                    owner = owners.get(header)
                    if owner is None:
                        breaches.append(f"{where}: {name} includes {header}, which no module provides")
                    elif owner not in allowed:
                        breaches.append(f"{where}: {name} includes {header} of module {owner}, "
                                        f"which it does not link (it may use: {', '.join(sorted(allowed)) or 'nothing of ours'})")
    return breaches


def size_breaches(source_root):
    """Folders over MAX_FOLDER_LINES lines of source directly inside, files over MAX_FILE_LINES."""
    breaches = []
    for folder, dirs, files in os.walk(source_root):
        rel = os.path.relpath(folder, source_root)
        dirs[:] = [d for d in dirs if not d.startswith(".")]
        # Tests aside, and build trees wherever BUILD_DIR put them (CMake's generated sources are not ours).
        if rel == "tests" or rel.startswith("tests" + os.sep) or "CMakeCache.txt" in files:
            dirs[:] = []
            continue
        total = 0
        for f in files:
            if Path(f).suffix not in SOURCE_SUFFIXES:
                continue
            lines = sum(1 for _ in open(os.path.join(folder, f), errors="replace"))
            total += lines
            if lines > MAX_FILE_LINES:
                breaches.append(f"{os.path.join(rel, f)}: {lines} lines (at most {MAX_FILE_LINES})")
        if total > MAX_FOLDER_LINES:
            breaches.append(f"{rel}/: {total} lines of source directly inside (at most {MAX_FOLDER_LINES})")
    return breaches


NAMESPACE_OR_BRACE = re.compile(r"\bnamespace\s+([\w:]*)\s*\{|[{}]")
COMMENT_OR_STRING = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'', re.S)
FORWARD_DECLARATIONS = re.compile(r"(\s*(template\s*<[^>]*>\s*)?(class|struct)\s+\w+\s*;)*\s*")


def namespaces_opened(code):
    """(full name, line, whether the block only forward-declares classes) of every named namespace that
    code opens; anonymous ones add nothing to the names inside them."""
    opened, stack = [], []  # stack: the enclosing namespace's name ('' if anonymous) or None for other braces
    for match in NAMESPACE_OR_BRACE.finditer(code):
        if match.group(0) == "}":
            entry = stack.pop() if stack else None
            if entry is not None and entry[1] is not None:
                opened[entry[1]][2] = bool(FORWARD_DECLARATIONS.fullmatch(code[entry[2]:match.start()]))
        elif match.group(0) == "{":
            stack.append(None)
        else:
            outer = [e[0] for e in stack if e is not None and e[0]]
            name = match.group(1)
            index = None
            if name and all(e is not None for e in stack):
                index = len(opened)
                opened.append(["::".join(outer + [name]), code.count("\n", 0, match.start()) + 1, False])
            stack.append((name, index, match.end()))
    return [tuple(o) for o in opened]


def namespace_breaches(features_root, source_root):
    """Namespaces follow modules under features/: see the module docstring."""
    breaches = []
    for module_dir in sorted(p for p in Path(features_root).iterdir() if p.is_dir()):
        module = module_dir.name
        own = f"smseg::{module}"
        for path in sorted(p for p in module_dir.rglob("*") if p.suffix in SOURCE_SUFFIXES and p.is_file()):
            is_tool = "tools" in path.relative_to(module_dir).parts
            code = COMMENT_OR_STRING.sub(lambda m: "\n" * m.group(0).count("\n"), path.read_text(errors="replace"))
            for name, line, forward_only in namespaces_opened(code):
                if name == own or name.startswith(own + "::") or forward_only:
                    continue
                if is_tool and not (name == "smseg" or name.startswith("smseg::")):
                    continue  # a program's own namespace
                breaches.append(f"{os.path.relpath(path, source_root)}:{line}: namespace {name} in module "
                                f"{module} (its sources declare {own} and namespaces inside it)")
    return breaches


def check(modules_json, source_root):
    layers = load_layers(modules_json)
    breaches = [f"module {n} links itself through its dependencies" for n in cycles(layers)]
    breaches += include_breaches(layers, source_root)
    breaches += size_breaches(source_root)
    if (Path(source_root) / "features").is_dir():
        breaches += namespace_breaches(Path(source_root) / "features", source_root)
    return breaches


def self_test():
    """A two-module tree: 'low' below 'high'. Clean, it passes; a forbidden include or a file of 901
    lines in 'low' is reported. Shows that the check can fail."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for name in ("low", "high"):
            (root / name / "include" / "smseg" / name).mkdir(parents=True)
            (root / name / "src").mkdir()
            (root / name / "include" / "smseg" / name / f"{name}.hpp").write_text("#pragma once\n")
        (root / "low" / "src" / "low.cpp").write_text('#include "smseg/low/low.hpp"\n')
        (root / "high" / "src" / "high.cpp").write_text('#include "smseg/low/low.hpp"\n#include "smseg/high/high.hpp"\n')
        modules = root / "modules.json"
        modules.write_text(json.dumps([
            {"kind": "module", "name": "low", "dir": str(root / "low"), "deps": []},
            {"kind": "module", "name": "high", "dir": str(root / "high"), "deps": ["low"]}]))
        failures = []
        if check(modules, root):
            failures.append(f"the clean tree was reported: {check(modules, root)}")
        (root / "low" / "src" / "low.cpp").write_text('#include "smseg/high/high.hpp"\n')
        if not any("low includes smseg/high/high.hpp of module high" in b for b in check(modules, root)):
            failures.append("an upward include was not reported")
        (root / "low" / "src" / "low.cpp").write_text("int x;\n" * 901)
        if not any("901 lines" in b for b in check(modules, root)):
            failures.append("a 901-line file was not reported")
        failures += namespace_self_test(root / "features")
    for f in failures:
        print(f"self-test: {f}")
    return 1 if failures else 0


def namespace_self_test(features):
    """features/low/: its own namespace, one nested, an anonymous one, a forward declaration of another
    smseg namespace and a tool's own namespace pass; smseg::features, or smseg::high with a definition in
    it, are reported."""
    (features / "low" / "src").mkdir(parents=True)
    (features / "low" / "tools").mkdir()
    source = features / "low" / "src" / "low.cpp"
    (features / "low" / "tools" / "tool.cpp").write_text("namespace tool {\nint x;\n}  // namespace tool\n")
    source.write_text("namespace smseg::options {\ntemplate <class S>\nclass Table;  // a { b\n}\n"
                      "namespace smseg::low {\nnamespace detail {\nstruct A { int f() { return 0; } };\n}\n"
                      "namespace {\nint y;\n}\n}  // namespace smseg::low\n")
    failures = []
    if namespace_breaches(features, features):
        failures.append(f"clean namespaces were reported: {namespace_breaches(features, features)}")
    for foreign in ("smseg::features", "smseg::high"):
        source.write_text(f"namespace smseg::low {{\n}}\nnamespace {foreign} {{\nint z;\n}}\n")
        if not any(f"low.cpp:3: namespace {foreign} in module low" in b for b in namespace_breaches(features, features)):
            failures.append(f"namespace {foreign} in module low was not reported")
    return failures


def main(argv):
    if argv[1:] == ["--self-test"]:
        return self_test()
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    source_root = Path(__file__).resolve().parents[2]
    breaches = check(argv[1], source_root)
    for b in breaches:
        print(b)
    print(f"layering: {len(load_layers(argv[1]))} layers, {len(breaches)} breaches")
    return 1 if breaches else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
