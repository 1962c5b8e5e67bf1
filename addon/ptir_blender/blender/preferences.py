"""The add-on's preferences as the rest of the add-on reads them: which `ptir` to run, whether to keep job files."""

import os

import bpy

from ..io import cli


def _preferences():
    addon = bpy.context.preferences.addons.get(__package__.rsplit(".", 1)[0])
    return addon.preferences if addon is not None else None


def cli_path():
    prefs = _preferences()
    return cli.find_cli(prefs.cli_path if prefs is not None else "")


def keep_files():
    prefs = _preferences()
    return bool(prefs is not None and prefs.keep_files) or bool(os.environ.get("PTIR_KEEP_FILES"))
