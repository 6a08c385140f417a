"""report.html says what made it: refsoft's version, the date, the machine, the command."""

import refsoft
from refsoft.bench import report


def test_report_opens_with_its_provenance(tmp_path):
    path = report.write_report(str(tmp_path), "T", [("p", "x")])
    page = open(path).read()
    p = report.provenance()
    assert p["refsoft"] == refsoft.__version__ and p["date"].endswith("UTC")
    for key in ("refsoft", "date", "machine", "software", "command"):
        assert f"<b>{key}</b>: " in page
    assert "called from Python" in page  # no command line made this one
    token = report.COMMAND.set("refsoft bench table1 --scenes ants <&>")
    try:
        page = open(report.write_report(str(tmp_path), "T", [])).read()
    finally:
        report.COMMAND.reset(token)
    assert "<code>refsoft bench table1 --scenes ants &lt;&amp;&gt;</code>" in page
    assert report.COMMAND.get() is None
