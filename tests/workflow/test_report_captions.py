"""Every figure and table caption of the Snakemake report (workflows/report/*.rst) is
valid reStructuredText: a stray ``|x|`` is a substitution reference, and the report then
shows docutils' error message in place of the text."""
import io
from pathlib import Path

import docutils.core
import pytest

CAPTIONS = sorted((Path(__file__).resolve().parents[2] / "workflows" / "report").glob("*.rst"))


@pytest.mark.parametrize("path", CAPTIONS, ids=[p.stem for p in CAPTIONS])
def test_caption_renders_without_warnings(path):
    warnings = io.StringIO()
    docutils.core.publish_string(path.read_text(), writer_name="html",
                                 settings_overrides={"warning_stream": warnings,
                                                     "report_level": 2})
    assert warnings.getvalue() == ""


def test_captions_are_found():
    assert len(CAPTIONS) >= 10
