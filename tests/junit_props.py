"""The ``<property name=... value=...>`` elements of a JUnit file as a dict, read one way by every
test that checks them (a property with no name or value reads as "")."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Dict, Iterable


def _as_dict(props: Iterable[ET.Element]) -> Dict[str, str]:
    return {p.get("name", ""): p.get("value", "") for p in props}


def properties(element: ET.Element) -> Dict[str, str]:
    """Every property at any depth below ``element``: a testcase's own, or for a whole file its
    suites' and cases' together (a later one of the same name wins)."""
    return _as_dict(element.iter("property"))


def suite_properties(element: ET.Element) -> Dict[str, str]:
    """A suite's own properties, not its cases': ``element`` is a ``<testsuite>``, or the
    ``<testsuites>`` root (every suite in it)."""
    path = "testsuite/properties/property" if element.tag == "testsuites" else "properties/property"
    return _as_dict(element.findall(path))
