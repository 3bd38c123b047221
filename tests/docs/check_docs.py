#!/usr/bin/env python3
"""Keeps the documentation and the code together (ctest docs.check).

    check_docs.py --tracemesh BIN --tracemeshd BIN --source DIR

Checks, and prints one line per thing that is missing or wrong:
  - every option of `tracemesh --help` is in docs/cli.md, every option of `tracemeshd --help` in docs/deploy.md;
  - conversely, every option those pages give to the program exists in its --help. An option counts as given to
    the program when it is the first word of an inline code span (`--density 2`), or anywhere in an inline span or
    a code-block line that runs the program (`tracemeshd --listen ...`, `build/bin/tracemesh fas2.pqr ...`);
    options of other commands (docker, curl, cmake) are theirs;
  - proto/openapi.json repeats no key within an object (JSON readers keep the last one silently);
  - every path with every method of proto/openapi.json is in docs/api.md as `METHOD /path`, and every parameter
    name (query, path and header parameters, multipart fields) as `name`; conversely every name in the first
    column of an api.md table whose first header cell is "parameter" or "field" exists in the OpenAPI document;
  - README.md is at most 12 KiB;
  - every relative link of README.md, CHANGELOG.md and docs/**/*.md resolves to a file of the repository, and a
    link to a heading of a Markdown page (page.md#anchor) to a heading or an <a id> of that page;
  - no documentation file mentions a path outside the repository (the shared folder beside the checkout, /work/).
Exits 0 when everything holds, 1 otherwise.
"""
import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

README_MAX_BYTES = 12 * 1024
# Built from parts so that this file does not itself name the folder it forbids.
OUTSIDE_PATHS = ("/".join(("..", "shared")), "/work/")
OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
HTTP_METHODS = ("get", "put", "post", "delete", "patch", "head", "options")


def help_options(binary):
    """The long options a program's --help lists (the first column of each option line)."""
    text = subprocess.run([binary, "--help"], capture_output=True, text=True, check=False).stdout
    options = set()
    for line in text.splitlines():
        match = re.match(r"\s+(?:-\w,)?(--[a-z][a-z0-9-]*)", line)
        if match:
            options.add(match.group(1))
    if not options:
        raise SystemExit(f"check_docs.py: {binary} --help listed no option")
    return options


def code_blocks_and_prose(text):
    """(lines inside fenced code blocks, the text outside them)."""
    block_lines, prose, inside = [], [], False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            inside = not inside
            continue
        (block_lines if inside else prose).append(line)
    return block_lines, "\n".join(prose)


def runs_program(words, program):
    return bool(words) and re.fullmatch(rf"(?:\S*/)?{re.escape(program)}", words[0]) is not None


def options_given_to(text, program):
    """The options a page gives to `program` (see the module's docstring), each with where it was seen."""
    given = {}
    block_lines, prose = code_blocks_and_prose(text)
    command = ""
    for line in block_lines:  # a command continued with a trailing backslash is one line
        command += line.rstrip("\\") + " "
        if line.rstrip().endswith("\\"):
            continue
        words = command.split()
        if runs_program(words, program):
            for option in OPTION.findall(command):
                given.setdefault(option, command.strip()[:80])
        command = ""
    for span in re.findall(r"`([^`\n]+)`", prose):
        words = span.split()
        if runs_program(words, program):
            for option in OPTION.findall(span):
                given.setdefault(option, span[:80])
        elif words and OPTION.fullmatch(words[0].split("=")[0]):
            given.setdefault(words[0].split("=")[0], span[:80])
    return given


def check_options(failures, page, program, options, text):
    for option in sorted(options):
        if not re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", text):
            failures.append(f"{page}: option {option} of `{program} --help` is not documented")
    for option, where in sorted(options_given_to(text, program).items()):
        if option not in options:
            failures.append(f"{page}: {option} (in `{where}`) is not an option of `{program} --help`")


def openapi_names(document):
    """(['METHOD /path', ...], {parameter and multipart field names})."""
    operations, names = [], set()

    def resolve(item):
        while "$ref" in item:
            node = document
            for part in item["$ref"].lstrip("#/").split("/"):
                node = node[part]
            item = node
        return item

    for path, item in document["paths"].items():
        for parameter in item.get("parameters", []):
            names.add(resolve(parameter)["name"])
        for method, operation in item.items():
            if method not in HTTP_METHODS:
                continue
            operations.append(f"{method.upper()} {path}")
            for parameter in operation.get("parameters", []):
                names.add(resolve(parameter)["name"])
            body = resolve(operation.get("requestBody", {}))
            for content in body.get("content", {}).values():
                names.update(resolve(content.get("schema", {})).get("properties", {}).keys())
    return operations, names


def parameter_table_names(text):
    """The first-column names of the tables whose first header cell is 'parameter' or 'field'."""
    names, in_table = [], False
    for line in text.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")] if line.lstrip().startswith("|") else None
        if cells is None:
            in_table = False
        elif not in_table:
            in_table = cells[0].lower() in ("parameter", "field")
        elif not re.fullmatch(r":?-+:?", cells[0]):
            names.extend(re.findall(r"`([^`]+)`", cells[0]))
    return names


def load_json_naming_repeated_keys(path, failures):
    """The JSON document; a key repeated within one object (the last one silently wins) is a failure."""
    def pairs_to_dict(pairs):
        seen = {}
        for key, value in pairs:
            if key in seen:
                where = dict(pairs).get("operationId") or sorted(k for k, _ in pairs if k != key)[:6]
                failures.append(f"proto/{path.name}: key \"{key}\" appears twice in one object ({where}); "
                                f"a JSON reader keeps only the last")
            seen[key] = value
        return seen
    return json.loads(path.read_text(encoding="utf-8"), object_pairs_hook=pairs_to_dict)


def check_api(failures, source):
    text = (source / "docs/api.md").read_text(encoding="utf-8")
    operations, names = openapi_names(load_json_naming_repeated_keys(source / "proto/openapi.json", failures))
    for operation in operations:
        if f"`{operation}`" not in text and not re.search(rf"`{re.escape(operation)}[?`]", text):
            failures.append(f"docs/api.md: route `{operation}` of proto/openapi.json is not documented")
    for name in sorted(names):
        if f"`{name}`" not in text:
            failures.append(f"docs/api.md: parameter `{name}` of proto/openapi.json is not documented")
    for name in parameter_table_names(text):
        if name not in names:
            failures.append(f"docs/api.md: parameter `{name}` of a parameter table is not in proto/openapi.json")


def heading_anchors(text):
    """GitHub's anchors of a page's headings (lower case, punctuation dropped, spaces to hyphens, -1 on repeats)."""
    anchors, seen = set(re.findall(r'<a (?:id|name)="([^"]+)"', text)), {}
    _, prose = code_blocks_and_prose(text)
    for match in re.finditer(r"^#{1,6}\s+(.+?)\s*#*$", prose, re.MULTILINE):
        slug = re.sub(r"[^\w\- ]", "", match.group(1).strip().lower()).replace(" ", "-")
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        anchors.add(slug if count == 0 else f"{slug}-{count}")
    return anchors


def doc_pages(source):
    pages = [source / "README.md", source / "CHANGELOG.md"] + sorted((source / "docs").rglob("*.md"))
    return [page for page in pages if page.is_file()]


def check_links(failures, source):
    for page in doc_pages(source):
        _, prose = code_blocks_and_prose(page.read_text(encoding="utf-8"))
        prose = re.sub(r"`[^`\n]*`", "", prose)
        for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", prose):
            if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("//"):
                continue  # an absolute URL
            file_part, _, anchor = target.partition("#")
            linked = (page.parent / file_part).resolve() if file_part else page.resolve()
            where = f"{page.relative_to(source)}: link ({target})"
            if not linked.exists() or source.resolve() not in [linked, *linked.parents]:
                failures.append(f"{where} names no file of the repository")
            elif anchor and linked.suffix == ".md" and anchor not in heading_anchors(linked.read_text(encoding="utf-8")):
                failures.append(f"{where} names no heading of {linked.relative_to(source.resolve())}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracemesh", required=True)
    parser.add_argument("--tracemeshd", required=True)
    parser.add_argument("--source", required=True, type=Path)
    arguments = parser.parse_args()
    source = arguments.source
    failures = []
    for page, program, binary in (("docs/cli.md", "tracemesh", arguments.tracemesh),
                                  ("docs/deploy.md", "tracemeshd", arguments.tracemeshd)):
        check_options(failures, page, program, help_options(binary), (source / page).read_text(encoding="utf-8"))
    check_api(failures, source)
    readme_bytes = (source / "README.md").stat().st_size
    if readme_bytes > README_MAX_BYTES:
        failures.append(f"README.md: {readme_bytes} bytes, more than {README_MAX_BYTES}")
    check_links(failures, source)
    for page in doc_pages(source):
        text = page.read_text(encoding="utf-8")
        for outside in OUTSIDE_PATHS:
            if outside in text:
                failures.append(f"{page.relative_to(source)}: mentions {outside}, a path outside the repository")
    for failure in failures:
        print(failure)
    print(f"check_docs.py: {len(failures)} problem(s)" if failures else "check_docs.py: the documentation matches")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
