"""Hypothesis strategies for JSON documents, shared by the rooms whose readers take JSON
(tests/io, tests/head). Import them from any room (``from json_strategies import
json_documents``; tests/ is on sys.path through the root conftest)."""

from __future__ import annotations

from hypothesis import strategies as st


def json_documents(leaves: st.SearchStrategy, *, max_size: int = 4, key_size: int = 8,
                   max_leaves: int = 20) -> st.SearchStrategy:
    """JSON values built from ``leaves``: lists and objects of at most ``max_size``
    items, keys of at most ``key_size`` characters, ``max_leaves`` leaves at most."""
    return st.recursive(
        leaves,
        lambda children: st.lists(children, max_size=max_size)
        | st.dictionaries(st.text(max_size=key_size), children, max_size=max_size),
        max_leaves=max_leaves)
