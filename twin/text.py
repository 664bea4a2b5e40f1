"""Reading what users type: YAML mappings with the line of every key, key paths, close-match hints.

Shared by every file format of the project (scenarios, part files, studies) so that each bad input
gets the same kind of one-line message: ``file:line: key.path: what was expected``.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

import yaml

from twin.errors import ScenarioError


def did_you_mean(name: object, options: Iterable, *, label: str | None = "valid", sort: bool = True) -> str:
    """``"; did you mean 'x'?"`` for the option closest to ``name``.

    Without a close option: ``"; <label>: a, b, c"`` (the options, sorted unless ``sort=False``),
    or ``""`` when ``label`` is None.

    Parameters
    ----------
    name : object
        What the user typed.
    options : iterable
        Valid values.
    label : str or None
        Heading of the option list.
    sort : bool
        Sort the option list.

    Returns
    -------
    str
        The hint, starting with ``"; "``, or ``""``.
    """
    options = [str(o) for o in options]
    close = difflib.get_close_matches(str(name), options, n=1)
    if close:
        return f"; did you mean {close[0]!r}?"
    if label is None:
        return ""
    return f"; {label}: {', '.join(sorted(options) if sort else options)}"


# libyaml's parser where PyYAML was built with it: the same events, nodes, marks and safe
# constructor as yaml.SafeLoader, several times faster (a scenario is parsed three times below)
LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _compose(text: str) -> yaml.Node | None:
    """The YAML node tree (None for an empty or unparsable document: safe_load says why)."""
    try:
        return yaml.compose(text, Loader=LOADER)
    except yaml.YAMLError:
        return None


def line_map(text: str, root: yaml.Node | None = None) -> dict[tuple, int]:
    """Key path → 1-based YAML line, from the composed node tree (list items by index); ``root``:
    the tree already composed from ``text``.

    Parameters
    ----------
    text : str
        YAML text.
    root : yaml.Node, optional
        Its composed tree.

    Returns
    -------
    dict of tuple to int
        Line of each key path.
    """
    lines: dict[tuple, int] = {}

    def walk(node: yaml.Node, path: tuple) -> None:
        lines.setdefault(path, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                sub = path + (_scalar(key),)
                lines[sub] = key.start_mark.line + 1
                walk(value, sub)
        elif isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                walk(item, path + (i,))

    root = root if root is not None else _compose(text)
    if root is not None:
        walk(root, ())
    return lines


def _scalar(key: yaml.Node):
    """A mapping key as ``safe_load`` reads it (``2:`` → 2, ``"2":`` → "2"), so look-ups match the data."""
    if not isinstance(key, yaml.ScalarNode):
        return key.value
    try:
        value = yaml.SafeLoader("").construct_object(key)
        hash(value)
    except (yaml.YAMLError, TypeError):
        return key.value
    return value


def format_path(loc: tuple) -> str:
    """``('program', 'steps', 1, 'dwell_s')`` → ``program.steps[1].dwell_s``.

    Parameters
    ----------
    loc : tuple
        Key path (str keys, int list indices).

    Returns
    -------
    str
        Dotted path, ``(top level)`` for an empty one.
    """
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def where(path: str, lines: dict[tuple, int], loc: tuple) -> str:
    """``file:line`` of the deepest part of ``loc`` the YAML has (``file`` alone if none).

    Parameters
    ----------
    path : str
        The file.
    lines : dict of tuple to int
        :func:`line_map` of it.
    loc : tuple
        Key path.

    Returns
    -------
    str
        ``file:line`` or ``file``.
    """
    for n in range(len(loc), -1, -1):
        if loc[:n] in lines:
            return f"{path}:{lines[loc[:n]]}"
    return path


# a scenario or study is a few levels deep with a handful of anchors: far beyond these is an attack
# (billion laughs, self-reference) or a generated file gone wrong, refused before anything is built
MAX_YAML_DEPTH = 64
MAX_YAML_NODES = 200_000  # after alias expansion


def check_yaml_limits(text: str, path: str, loader: type | None = None) -> None:
    """Refuse YAML nested deeper than :data:`MAX_YAML_DEPTH`, larger than :data:`MAX_YAML_NODES`
    once aliases are expanded, or with an alias to a collection still open (a self-reference).

    Parameters
    ----------
    text : str
        YAML text.
    path : str
        The file, for messages.
    loader : type, optional
        The PyYAML loader whose parser emits the events (default :data:`LOADER`). When libyaml's
        stops with an error of its own (it has its own nesting limit), the pure-Python parser reads
        on to the first limit of ours.
    """
    loader = loader or LOADER
    sizes: dict[str, int] = {}
    stack: list[list] = [[None, 0]]  # per open collection: its anchor, its expanded node count
    try:
        for event in yaml.parse(text, Loader=loader):
            line = event.start_mark.line + 1
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                stack.append([event.anchor, 1])
                if len(stack) - 1 > MAX_YAML_DEPTH:
                    raise ScenarioError(f"{path}:{line}: YAML nested deeper than {MAX_YAML_DEPTH} levels; "
                                        "expected a plain mapping")
                continue
            if isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                anchor, count = stack.pop()
                if anchor is not None:
                    sizes[anchor] = count
            elif isinstance(event, yaml.AliasEvent):
                if any(event.anchor == a for a, _ in stack):
                    raise ScenarioError(f"{path}:{line}: alias *{event.anchor} refers to the collection that "
                                        "contains it; expected a finite document")
                count = sizes.get(event.anchor, 1)
            elif isinstance(event, yaml.ScalarEvent):
                count = 1
                if event.anchor is not None:
                    sizes[event.anchor] = 1
            else:
                continue
            stack[-1][1] += count
            if stack[-1][1] > MAX_YAML_NODES:
                raise ScenarioError(f"{path}:{line}: more than {MAX_YAML_NODES} values once its aliases are "
                                    "expanded; expected a plain document")
    except yaml.YAMLError:
        if loader is not yaml.SafeLoader:
            check_yaml_limits(text, path, yaml.SafeLoader)
        return  # the parser's own message comes from safe_load, with its line


def check_duplicate_keys(root: yaml.Node | None, path: str) -> None:
    """Refuse a mapping of the tree ``root`` that holds the same key twice: YAML loaders keep the
    last one in silence, so a repeated unit id or parameter would drop the first without a word.

    Parameters
    ----------
    root : yaml.Node or None
        Composed tree.
    path : str
        The file, for messages.
    """
    seen, todo = set(), [root] if root is not None else []
    while todo:
        node = todo.pop()
        if id(node) in seen:  # an alias: the same node again, already checked
            continue
        seen.add(id(node))
        if isinstance(node, yaml.MappingNode):
            first: dict = {}
            for key, value in node.value:
                if isinstance(key, yaml.ScalarNode) and key.tag != "tag:yaml.org,2002:merge":
                    k = (key.tag, key.value)
                    if k in first:
                        raise ScenarioError(f"{path}:{key.start_mark.line + 1}: key {key.value!r} appears twice in one "
                                            f"mapping (first at line {first[k]}); expected each key once")
                    first[k] = key.start_mark.line + 1
                todo += [key, value]
        elif isinstance(node, yaml.SequenceNode):
            todo += node.value


def load_yaml_mapping(text: str, path: str, what: str) -> tuple[dict, dict[tuple, int]]:
    """Parse YAML that must be a mapping; return it with its key-path → line map.

    Parameters
    ----------
    text : str
        YAML text.
    path : str
        The file, for messages.
    what : str
        What the document should be, for the message when it is not a mapping.

    Returns
    -------
    data : dict
        The mapping.
    lines : dict of tuple to int
        Line of each key path.

    Raises
    ------
    ScenarioError
        ``path:line: malformed YAML: ...`` or ``path: <what>, got list``.
    """
    check_yaml_limits(text, path)
    root = _compose(text)
    check_duplicate_keys(root, path)
    try:
        try:
            data = yaml.load(text, Loader=LOADER)
        except yaml.YAMLError:  # the pure-Python parser names the offending character and its line
            data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f":{mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ScenarioError(f"{path}{line}: malformed YAML: {problem}") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: {what}, got {type(data).__name__}")
    return data, line_map(text, root)
