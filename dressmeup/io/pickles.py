"""Bound what a pickle would build before anything is unpickled.

A restricted unpickler decides *which* callables a pickle may name, not *how much* it
builds: 200 bytes of nested lists that each hold ten references to the list below ("billion
laughs") unpickle into a small graph that any walk which copies it (cleaning, converting,
printing) expands into 10^9 objects. :func:`scan_pickle` reads the opcodes only
(:mod:`pickletools`, nothing is called or built), mirrors the unpickler's stack and memo as
a graph of references, and refuses

- more objects than the ``pickle_objects`` limit, counting every shared reference once more
  (the graph's size as a tree: what a walk would build), or a structure that contains
  itself;
- out-of-band buffers (protocol 5), unknown opcodes, truncated data or a byte string
  declaring more bytes than the file holds,

each as an :class:`~dressmeup.errors.InputError` naming the file. The file's size itself is
bounded by ``pickle_bytes`` (:func:`read_pickle_bytes`).
"""

from __future__ import annotations

import os
import pickletools
from dataclasses import dataclass

from dressmeup.errors import InputError
from dressmeup.limits import PICKLE_BYTES, PICKLE_OBJECTS, bounded_file

_MARK = object()
_LEAF = object()
_PUSH_LEAF = {
    "INT", "BININT", "BININT1", "BININT2", "LONG", "LONG1", "LONG4", "STRING", "BINSTRING",
    "SHORT_BINSTRING", "BINBYTES", "SHORT_BINBYTES", "BINBYTES8", "BYTEARRAY8", "UNICODE",
    "BINUNICODE", "SHORT_BINUNICODE", "BINUNICODE8", "FLOAT", "BINFLOAT", "NONE", "NEWTRUE",
    "NEWFALSE", "GLOBAL", "PERSID", "EXT1", "EXT2", "EXT4",
}
_EMPTY = {"EMPTY_LIST", "EMPTY_DICT", "EMPTY_TUPLE", "EMPTY_SET"}
_FROM_MARK = {"LIST", "TUPLE", "DICT", "FROZENSET", "INST", "OBJ"}
_INTO_TOP_FROM_MARK = {"APPENDS", "SETITEMS", "ADDITEMS"}
_POP_INTO_NEW = {"TUPLE1": 1, "TUPLE2": 2, "TUPLE3": 3, "REDUCE": 2, "NEWOBJ": 2,
                 "NEWOBJ_EX": 3, "STACK_GLOBAL": 2, "BINPERSID": 1}
_POP_INTO_TOP = {"APPEND": 1, "SETITEM": 2, "BUILD": 1}


@dataclass(frozen=True)
class PickleScan:
    """What :func:`scan_pickle` counted: ``objects`` created by the opcodes and
    ``expanded``, the objects of the result counted as a tree (every shared reference once
    more)."""

    objects: int
    expanded: int


def read_pickle_bytes(path: str | os.PathLike) -> bytes:
    """The bytes of a pickle file after checking its size (``pickle_bytes``) and what it
    would build (:func:`scan_pickle`).

    Raises
    ------
    FileNotFoundError, InputError
    """
    data = bounded_file(path, "pickle", PICKLE_BYTES).read_bytes()
    scan_pickle(data, str(path))
    return data


def _pop_to_mark(stack: list, source: str) -> list:
    items = []
    while stack:
        x = stack.pop()
        if x is _MARK:
            items.reverse()
            return items
        items.append(x)
    raise InputError(f"{source}: damaged pickle (a MARK is missing)")


def _pop(stack: list, n: int, source: str) -> list:
    if len(stack) < n or any(x is _MARK for x in stack[len(stack) - n:]):
        raise InputError(f"{source}: damaged pickle (stack underflow)")
    items = stack[len(stack) - n:]
    del stack[len(stack) - n:]
    return items


def _top(stack: list, source: str) -> list:
    if not stack or stack[-1] is _MARK or stack[-1] is _LEAF:
        raise InputError(f"{source}: damaged pickle (no container to add to)")
    return stack[-1]


def scan_pickle(data: bytes, source: str = "pickle") -> PickleScan:
    """Count what unpickling ``data`` would build, without unpickling it.

    Raises
    ------
    InputError
        Damaged, truncated or unsupported pickle, out-of-band buffers, a structure that
        contains itself; :class:`~dressmeup.limits.LimitError` beyond ``pickle_objects``.
    """
    bound = PICKLE_OBJECTS.value()
    stack: list = []
    memo: dict = {}
    created = 0
    result = None
    try:
        for op, arg, _pos in pickletools.genops(data):
            name = op.name
            if name in _PUSH_LEAF:
                stack.append(_LEAF)
                created += 1
            elif name in _EMPTY:
                stack.append([])
                created += 1
            elif name == "MARK":
                stack.append(_MARK)
            elif name in _FROM_MARK:
                stack.append(_pop_to_mark(stack, source))
                created += 1
            elif name in _INTO_TOP_FROM_MARK:
                items = _pop_to_mark(stack, source)
                _top(stack, source).extend(items)
            elif name in _POP_INTO_NEW:
                stack.append(_pop(stack, _POP_INTO_NEW[name], source))
                created += 1
            elif name in _POP_INTO_TOP:
                items = _pop(stack, _POP_INTO_TOP[name], source)
                _top(stack, source).extend(items)
            elif name in ("PUT", "BINPUT", "LONG_BINPUT", "MEMOIZE"):
                if not stack or stack[-1] is _MARK:
                    raise InputError(f"{source}: damaged pickle (nothing to memoize)")
                memo[len(memo) if name == "MEMOIZE" else arg] = stack[-1]
            elif name in ("GET", "BINGET", "LONG_BINGET"):
                if arg not in memo:
                    raise InputError(f"{source}: damaged pickle (memo {arg} read before "
                                     "it is written)")
                stack.append(memo[arg])
            elif name == "DUP":
                if not stack or stack[-1] is _MARK:
                    raise InputError(f"{source}: damaged pickle (nothing to duplicate)")
                stack.append(stack[-1])
            elif name == "POP":
                _pop(stack, 1, source)
            elif name == "POP_MARK":
                _pop_to_mark(stack, source)
            elif name in ("PROTO", "FRAME"):
                pass
            elif name == "STOP":
                result = stack[-1] if stack else None
                break
            else:  # NEXT_BUFFER, READONLY_BUFFER and anything newer
                raise InputError(f"{source}: the pickle uses opcode {name}, which model and "
                                 "data files never need; refused")
            if created > bound:
                PICKLE_OBJECTS.check(created, source)
    except InputError:
        raise
    except (ValueError, IndexError, KeyError) as exc:  # pickletools on damaged data
        raise InputError(f"{source}: not a readable pickle ({exc})") from exc
    if result is None:
        raise InputError(f"{source}: not a readable pickle (no STOP)")
    return PickleScan(created, _expanded(result, bound, source))


def _expanded(root, bound: int, source: str) -> int:
    """Size of ``root`` as a tree (every reference counted), refused beyond ``bound``."""
    if root is _LEAF:
        return 1
    weight: dict[int, int] = {}
    on_path: set[int] = set()
    todo: list = [(root, False)]
    while todo:
        node, done = todo.pop()
        key = id(node)
        if done:
            on_path.discard(key)
            total = 1 + sum(1 if c is _LEAF else weight[id(c)] for c in node)
            if total > bound:
                PICKLE_OBJECTS.check(total, source, "objects the pickle builds (every shared "
                                     "reference counted)")
            weight[key] = total
            continue
        if key in weight:
            continue
        if key in on_path:
            raise InputError(f"{source}: the pickle holds a structure that contains itself; "
                             "refused")
        on_path.add(key)
        todo.append((node, True))
        for c in node:
            if c is not _LEAF:
                if id(c) in on_path:
                    raise InputError(f"{source}: the pickle holds a structure that contains "
                                     "itself; refused")
                if id(c) not in weight:
                    todo.append((c, False))
    return weight[id(root)]
