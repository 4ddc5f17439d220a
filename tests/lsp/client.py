"""A small LSP client (standard library only) that drives `lumo lsp` over stdio as an editor
would, and checks what a user sees: diagnostics at the positions `lumo validate` reports
(counted in UTF-16 code units, and in UTF-8 when the client asks for it, with non-ASCII text
before them on their line), cleared when fixed, none for a JSON file that is not lumo's,
completion of material names and of the schema's member names, hover on a field, go to
definition into an included fragment and from an include or asset path to its file.

Usage: client.py LUMO_EXECUTABLE
"""

import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import queue
import time
from pathlib import Path
from urllib.parse import quote

TIMEOUT = 20.0


class Client:
    def __init__(self, lumo, cwd):
        self.proc = subprocess.Popen(
            [lumo, "lsp"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, cwd=cwd
        )
        self.next_id = 0
        self.messages = queue.Queue()
        self.seen = []  # every message from the server, in order
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        out = self.proc.stdout
        while True:
            headers = {}
            while True:
                line = out.readline()
                if not line:
                    return
                line = line.decode().strip()
                if not line:
                    break
                name, value = line.split(":", 1)
                headers[name.lower()] = value.strip()
            body = out.read(int(headers["content-length"]))
            message = json.loads(body)
            self.seen.append(message)
            self.messages.put(message)

    def send(self, message):
        message["jsonrpc"] = "2.0"
        body = json.dumps(message).encode()
        self.proc.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        self.proc.stdin.flush()

    def notify(self, method, params):
        self.send({"method": method, "params": params})

    def request(self, method, params):
        self.next_id += 1
        self.send({"id": self.next_id, "method": method, "params": params})
        return self.wait(lambda m: m.get("id") == self.next_id and "method" not in m)["result"]

    def wait(self, accept):
        deadline = time.monotonic() + TIMEOUT
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError("no answer from lumo lsp within %.0f s" % TIMEOUT)
            message = self.messages.get(timeout=left)
            if accept(message):
                return message

    def diagnostics(self, uri):
        """The next diagnostics published for `uri`."""
        m = self.wait(
            lambda m: m.get("method") == "textDocument/publishDiagnostics"
            and m["params"]["uri"] == uri
        )
        return m["params"]["diagnostics"]


def uri(path):
    return "file://" + quote(str(path))


def units(text, encoding):
    """The length of `text` in the code units of an LSP position encoding."""
    if encoding == "utf-16":
        return len(text.encode("utf-16-le")) // 2
    if encoding == "utf-8":
        return len(text.encode("utf-8"))
    return len(text)


def character(path, line, column, encoding):
    """The LSP character of `lumo validate`'s column (which counts characters) on a line."""
    text = Path(path).read_text(encoding="utf-8").split("\n")[line - 1]
    return units(text[: column - 1], encoding)


def validate(lumo, path):
    """(file, line, column, 'path: message') of every problem `lumo validate` prints."""
    out = subprocess.run([lumo, "validate", str(path)], capture_output=True, encoding="utf-8")
    found = set()
    for line in out.stderr.splitlines():
        m = re.match(r"^  (.+?):(\d+):(\d+): (.*?)(?: \(help: .*\))?$", line)
        if m:
            found.add((m[1], int(m[2]), int(m[3]), m[4]))
    return found


def main():
    lumo = sys.argv[1]
    tmp = Path(tempfile.mkdtemp())
    lib = tmp / "lib"
    lib.mkdir()
    fragment = lib / "materials.json"
    fragment_text = (
        '{\n  "$schema": "scene-fragment.schema.json",\n'
        '  "materials": {\n    "🎨 rouge-écarlate": {"base_color": [0.8, 0.0, 0.1]}, '
        '"red": {"base_color": [0.8, 0.1, 0.1], "roughness": "low"}\n  }\n}\n'
    )
    fragment.write_text(fragment_text, encoding="utf-8")
    scene = tmp / "scene.json"
    broken = (
        '{\n  "format_version": 2,\n'
        '  "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov_y_deg": 40},\n'
        '  "include": ["lib/materials.json"],\n'
        '  "materials": {"white": {"base_color": [0.8, 0.8, 0.8]}},\n'
        '  "objects": [\n'
        '    {"sphere": {"center": [0, 0, 0], "radius": -1, "material": "red"}},\n'
        '    {"sphere": {"center": [0, 2, 0], "radius": 1, "material": "whte"}},\n'
        '    {"mesh": {"source": {"obj": "tri.obj"}, "material": "white"}}\n'
        "  ]\n}\n"
    )
    scene.write_text(broken, encoding="utf-8")
    (tmp / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", encoding="utf-8")
    reported = validate(lumo, scene)
    assert len(reported) == 3, reported
    # lumo validate counts characters; the protocol's default counts UTF-16 code units (the
    # emoji before the fragment's problem is one character and two code units).
    expected = {(f, l, character(f, l, col, "utf-16") + 1, m) for f, l, col, m in reported}
    assert expected != reported, expected

    c = Client(lumo, tmp)
    init = c.request(
        "initialize", {"processId": os.getpid(), "rootUri": uri(tmp), "capabilities": {}}
    )
    assert init["capabilities"]["positionEncoding"] == "utf-16", init
    c.notify("initialized", {})
    # A JSON file that is not a lumo scene (no lumo "$schema"): opened, it gets no diagnostics,
    # and no completion or hover.
    package = tmp / "package.json"
    package_text = '{\n  "name": "demo",\n  "version": "1.0.0",\n  "objects": 3\n}\n'
    package.write_text(package_text, encoding="utf-8")
    c.notify(
        "textDocument/didOpen",
        {
            "textDocument": {
                "uri": uri(package), "languageId": "json", "version": 1, "text": package_text,
            }
        },
    )
    at = {"line": 1, "character": 4}
    for method in ["textDocument/completion", "textDocument/hover"]:
        assert c.request(method, {"textDocument": {"uri": uri(package)}, "position": at}) is None
    c.notify(
        "textDocument/didOpen",
        {"textDocument": {"uri": uri(scene), "languageId": "json", "version": 1, "text": broken}},
    )
    # Published for the fragment and for the scene (in either order).
    got = {}
    while len(got) < 2:
        m = c.wait(lambda m: m.get("method") == "textDocument/publishDiagnostics")
        got[m["params"]["uri"]] = m["params"]["diagnostics"]
    seen = set()
    for file, diags in [(fragment, got[uri(fragment)]), (scene, got[uri(scene)])]:
        for d in diags:
            if d["message"].startswith("in "):
                continue  # the mark at the include that brought the fragment in
            start = d["range"]["start"]
            seen.add((str(file), start["line"] + 1, start["character"] + 1, d["message"]))
    assert seen == expected, "lsp %s\nvalidate %s" % (sorted(seen), sorted(expected))
    # The range of the fragment's problem covers its value, "low", in UTF-16 code units too.
    low = [d for d in got[uri(fragment)] if "roughness" in d["message"]][0]["range"]
    assert low["end"]["character"] - low["start"]["character"] == 5, low
    # Help text as related information.
    typo = [d for d in got[uri(scene)] if "whte" in d["message"]][0]
    assert "white" in typo["relatedInformation"][0]["message"], typo
    # The include that brings the fragment's problem in is marked.
    marks = [d for d in got[uri(scene)] if d["message"].startswith("in ")]
    assert marks and marks[0]["range"]["start"] == {"line": 3, "character": 14}, marks

    # Completion of material names (the scene's and the fragment's) while typing one.
    typing = broken.replace('"material": "whte"', '"material": "')
    c.notify(
        "textDocument/didChange",
        {"textDocument": {"uri": uri(scene), "version": 2}, "contentChanges": [{"text": typing}]},
    )
    line = typing.splitlines()[7]
    at = {"line": 7, "character": line.index('"material": "') + len('"material": "')}
    items = c.request(
        "textDocument/completion", {"textDocument": {"uri": uri(scene)}, "position": at}
    )
    labels = sorted(i["label"] for i in items)
    assert labels == ["red", "white", "🎨 rouge-écarlate"], labels

    # Completion of the schema's member names: a sphere's, inside the quotes of one, and the
    # top level's, where a member may start.
    line = typing.splitlines()[6]
    at = {"line": 6, "character": line.index('"radius"') + 1}
    items = c.request(
        "textDocument/completion", {"textDocument": {"uri": uri(scene)}, "position": at}
    )
    labels = {i["label"] for i in items}
    schema = json.loads((Path(__file__).parents[2] / "schema/scene.schema.json").read_text(encoding="utf-8"))
    assert labels == set(schema["$defs"]["Sphere"]["properties"]), labels
    assert all("insertText" not in i for i in items), items
    radius = [i for i in items if i["label"] == "radius"][0]
    assert "scene units" in radius["documentation"]["value"], radius
    at = {"line": 1, "character": 2}
    items = c.request(
        "textDocument/completion", {"textDocument": {"uri": uri(scene)}, "position": at}
    )
    labels = {i["label"] for i in items}
    assert {"camera", "include", "materials", "objects", "textures"} <= labels, labels
    assert "radius" not in labels, labels

    # Hover on a field: its schema documentation.
    line = typing.splitlines()[6]
    at = {"line": 6, "character": line.index("radius") + 2}
    hover = c.request("textDocument/hover", {"textDocument": {"uri": uri(scene)}, "position": at})
    assert "objects[0].sphere.radius" in hover["contents"]["value"], hover
    assert "scene units" in hover["contents"]["value"], hover

    # Go to the definition of `red`, in the included fragment.
    line = typing.splitlines()[6]
    at = {"line": 6, "character": line.index('"red"') + 2}
    found = c.request(
        "textDocument/definition", {"textDocument": {"uri": uri(scene)}, "position": at}
    )
    assert found["uri"] == uri(fragment), found
    red_at = units(fragment_text.splitlines()[3].split('"red"')[0], "utf-16")
    assert found["range"]["start"] == {"line": 3, "character": red_at}, found

    # Go to the file an include names, and the OBJ file a mesh reads.
    for line_no, text in [(3, "lib/materials.json"), (8, "tri.obj")]:
        line = typing.splitlines()[line_no]
        at = {"line": line_no, "character": line.index(text) + 3}
        found = c.request(
            "textDocument/definition", {"textDocument": {"uri": uri(scene)}, "position": at}
        )
        assert found and found["uri"] == uri(tmp / text), (text, found)

    # Fix the scene, then the fragment (unsaved, in the editor): every diagnostic is cleared.
    fixed = broken.replace('"radius": -1', '"radius": 1').replace("whte", "white")
    c.notify(
        "textDocument/didChange",
        {"textDocument": {"uri": uri(scene), "version": 3}, "contentChanges": [{"text": fixed}]},
    )
    left = c.diagnostics(uri(scene))
    assert [d for d in left if not d["message"].startswith("in ")] == [], left
    c.notify(
        "textDocument/didOpen",
        {
            "textDocument": {
                "uri": uri(fragment), "languageId": "json", "version": 1, "text": fragment_text,
            }
        },
    )
    c.notify(
        "textDocument/didChange",
        {
            "textDocument": {"uri": uri(fragment), "version": 2},
            "contentChanges": [{"text": fragment_text.replace('"low"', "0.4")}],
        },
    )
    cleared = {}
    while len(cleared) < 2 or any(cleared.values()):
        m = c.wait(lambda m: m.get("method") == "textDocument/publishDiagnostics")
        cleared[m["params"]["uri"]] = m["params"]["diagnostics"]
    assert cleared == {uri(scene): [], uri(fragment): []}, cleared

    c.request("shutdown", None)
    c.notify("exit", None)
    assert c.proc.wait(timeout=TIMEOUT) == 0
    published = [
        m["params"]["uri"] for m in c.seen if m.get("method") == "textDocument/publishDiagnostics"
    ]
    assert uri(package) not in published, published

    # A client that offers UTF-8 positions gets them: columns count bytes.
    c = Client(lumo, tmp)
    init = c.request(
        "initialize",
        {
            "processId": os.getpid(),
            "rootUri": uri(tmp),
            "capabilities": {"general": {"positionEncodings": ["utf-8", "utf-16"]}},
        },
    )
    assert init["capabilities"]["positionEncoding"] == "utf-8", init
    c.notify("initialized", {})
    c.notify(
        "textDocument/didOpen",
        {"textDocument": {"uri": uri(scene), "languageId": "json", "version": 1, "text": broken}},
    )
    diags = c.diagnostics(uri(fragment))
    want = {(l, character(f, l, col, "utf-8")) for f, l, col, _ in reported if f == str(fragment)}
    have = {(d["range"]["start"]["line"] + 1, d["range"]["start"]["character"]) for d in diags}
    assert have == want, (have, want)
    c.request("shutdown", None)
    c.notify("exit", None)
    assert c.proc.wait(timeout=TIMEOUT) == 0
    print("lumo lsp: ok")


if __name__ == "__main__":
    main()
