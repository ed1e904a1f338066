"""The files an MJCF model is read from: the main file, its ``<include>``s and its assets.

One job, before MuJoCo opens anything: list the model's files (``<include file>`` resolved
as MuJoCo resolves it, relative to the main file's folder, recursively) so that

- a file that is not a regular file (a FIFO, a device: MuJoCo would block on it or read
  without end) is refused by name and line before it is opened -- includes, and the
  ``file`` of meshes, height fields, textures and skins (``<compiler meshdir texturedir
  assetdir>`` applied);
- a problem found on the compiled model is reported at the file and line of its element,
  also when that element is in an included file (:func:`locate`).
"""
import re
from pathlib import Path

from eomc.runtime.readable import check_regular_file

__all__ = ["model_files", "check_files", "locate", "named_files"]

_ASSETS = {"mesh": "meshdir", "hfield": "meshdir", "skin": "meshdir", "texture": "texturedir"}


def _parse(path):
    from lxml import etree
    try:
        return etree.parse(str(path), etree.XMLParser(remove_comments=True)).getroot()
    except Exception:          # MuJoCo's own parser says what is wrong with it
        return None


def model_files(path, check=False):
    """[(path, root element or None)]: the main file, then each included file (depth first, in
    document order).  ``check``: refuse non-regular includes and assets (ModelFileError at the
    element's file and line) before anything is opened."""
    path = Path(path)
    base = path.parent
    out, seen = [], set()

    def visit(file):
        key = str(Path(file).resolve()) if Path(file).exists() else str(file)
        if key in seen:
            return
        seen.add(key)
        root = _parse(file)
        out.append((Path(file), root))
        if root is None:
            return
        for inc in root.iter("include"):
            name = inc.get("file")
            if not name:
                continue
            target = Path(name) if Path(name).is_absolute() else base / name
            if check:
                check_regular_file(target, "<include> file", file, inc.sourceline)
            if target.is_file():
                visit(target)
    if check:
        check_regular_file(path, "MJCF file")
    visit(path)
    if check:
        dirs = {"meshdir": None, "texturedir": None, "assetdir": None}
        for _, root in out:
            if root is None:
                continue
            for comp in root.iter("compiler"):
                for key in dirs:
                    if comp.get(key) is not None:
                        dirs[key] = comp.get(key)
        for file, root in out:
            if root is None:
                continue
            for tag, key in _ASSETS.items():
                for el in root.iter(tag):
                    name = el.get("file")
                    if not name:
                        continue
                    folder = dirs[key] if dirs[key] is not None else dirs["assetdir"]
                    target = Path(name)
                    if not target.is_absolute():
                        target = base / (folder or "") / name
                    check_regular_file(target, f"<{tag}> file", file, el.sourceline)
    return out


def check_files(path):
    """Refuse (ModelFileError) an include or asset that is not a regular file; see :func:`model_files`."""
    model_files(path, check=True)


# an actuator is written as its kind (<motor>, <general>, ...): a joint of the same name must not
# be found first (dm_control names an actuator as the joint it drives)
_KINDS = {"actuator": "actuator|motor|position|velocity|intvelocity|damper|cylinder|muscle|adhesion|general|plugin"}


def _search(text, tag, name):
    match = None
    if name:    # the <tag> of that name first (an equality is often named as the tendon it ties)
        tags = f"(?:{_KINDS.get(tag, tag)})"
        match = (re.search(rf"<{tags}\b[^>]*\bname\s*=\s*[\"']{re.escape(name)}[\"']", text)
                 or re.search(rf"<\w+\b[^>]*\bname\s*=\s*[\"']{re.escape(name)}[\"']", text))
    return match


def locate(path, tag, name=None):
    """(file, line) of the ``<tag`` element named ``name`` (else of any element so named), in the
    main file or an included one; else of the first ``<tag`` in any of them; else (path, None)."""
    texts = []
    for file, _ in model_files(path):
        try:
            texts.append((file, Path(file).read_text(errors="replace")))
        except OSError:
            continue
    for pattern in ([lambda t: _search(t, tag, name)] if name else []) + [lambda t: re.search(rf"<{tag}\b", t)]:
        for file, text in texts:
            match = pattern(text)
            if match:
                return str(file), text.count("\n", 0, match.start()) + 1
    return str(path), None


def locate_mujoco_error(path, message):
    """(file, line) of the element a MuJoCo compiler error ``message`` is about, or (path, None).

    MuJoCo reads ``<include>``d files into the main document and then reports their elements at
    "line 0" against the main file (a real line is MuJoCo's own, in the main file).  Found here
    in the included files, then the main one:

    - an element the message names by tag and quotes an attribute or value of (``Element
      'joint'`` and ``'bogus'`` of "unrecognized attribute: 'bogus'");
    - an element it names by tag alone (``Element 'badtag'``: "unrecognized element"), where
      only one element has that tag (else no line: a guess would point at the wrong one);
    - an element of the compiled model it names by name (``Element name 'j', id 0``: "axis too
      small in joint"), by :func:`locate` with the tag the message's first line ends with;
    - a file MuJoCo could not parse (``Include error: ... Line number=2``, reported at the main
      file's ``<include>``): the included file that does not parse, at MuJoCo's line in it."""
    files = model_files(path)
    include = re.search(r"Include error:.*?Line number=(\d+)", message, re.S)
    broken = [file for file, root in files[1:] if root is None]
    if include and broken:
        return str(broken[0]), int(include.group(1))
    line = re.search(r"\bline (\d+)", message)
    if line and int(line.group(1)) > 0:
        return str(path), int(line.group(1))
    first = message.strip().split("\n")[0]
    named = re.search(r"Element name '([^'\n]+)'", message)
    if named:
        tag = re.search(r"(\w+)\s*$", first)
        return locate(path, tag.group(1) if tag else r"\w+", named.group(1))
    element = re.search(r"Element '([\w-]+)'", message)
    if not element:
        return str(path), None
    texts = []
    for file, _ in files[1:] + files[:1]:        # included files first: "line 0" is theirs
        try:
            texts.append((file, Path(file).read_text(errors="replace")))
        except OSError:
            continue
    tag = re.escape(element.group(1))
    quoted = re.findall(r"'([^'\n]+)'", first)
    for file, text in texts:
        for q in quoted:
            q = re.escape(q)
            match = (re.search(rf"<{tag}\b[^>]*\s{q}\s*=", text)
                     or re.search(rf"<{tag}\b[^>]*=\s*[\"']{q}[\"']", text))
            if match:
                return str(file), text.count("\n", 0, match.start()) + 1
    if not quoted:
        hits = [(file, text, m) for file, text in texts for m in re.finditer(rf"<{tag}\b", text)]
        if len(hits) == 1:
            file, text, match = hits[0]
            return str(file), text.count("\n", 0, match.start()) + 1
    return str(path), None


def named_files(path, seen=None):
    """The files an MJCF file names (includes, meshes, textures, ...), resolved as MuJoCo
    resolves them, or None when one cannot be found (then a build of it is not reused:
    eomc.compiler.build.reuse hashes them with the model)."""
    import xml.etree.ElementTree as ET
    seen = set() if seen is None else seen
    path = Path(path).resolve()
    if path in seen:
        return []
    seen.add(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return None
    base = path.parent
    dirs = {"meshdir": None, "texturedir": None, "assetdir": None}
    for compiler in root.iter("compiler"):
        for k in dirs:
            if compiler.get(k):
                dirs[k] = compiler.get(k)
    found = []
    for element in root.iter():
        name = element.get("file")
        if not name:
            continue
        where = [dirs["meshdir"] if element.tag in ("mesh", "skin", "hfield") else
                 dirs["texturedir"] if element.tag == "texture" else None, dirs["assetdir"], ""]
        candidates = [base / d / name for d in where if d is not None] + [Path(name)]
        hit = next((c for c in candidates if c.is_file()), None)
        if hit is None:
            return None
        found.append(hit.resolve())
        if element.tag == "include":
            more = named_files(hit, seen)
            if more is None:
                return None
            found += more
    return found
