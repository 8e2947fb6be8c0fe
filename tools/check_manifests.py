#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Checks imucal's ecosystem manifests against their formats and the repository:

  versions   project(VERSION), include/imucal/version.hpp, library.json, idf_component.yml,
             tools/arduino/library.properties and CHANGELOG.md's newest entry are one version
  platformio library.json: every key a field of PlatformIO's library.json format, values of the
             types and patterns it accepts; srcDir, includeDir, the -I folders of flags, the
             examples and headers exist, every export pattern matches a file, and the source
             filter selects exactly the library's sources (cmake/imucal_parts.cmake): no test,
             tool or benchmark
  esp-idf    idf_component.yml: every key a field of the component manager's manifest format,
             dependency names and fields, tags and version as it accepts them, every files
             pattern matches; the root CMakeLists.txt, run as ESP-IDF's first pass runs it,
             registers exactly the library's sources and include folders
  arduino    tools/arduino/library.properties: every key a field of the Arduino library format
             (1.5), the required ones present, category one of its list, version semver

  tools/check_manifests.py [versions|platformio|esp-idf|arduino]...   (default: all)
"""
import fnmatch
import json
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
SEMVER = re.compile(r"^\d+\.\d+\.\d+(?:[-+][0-9A-Za-z.-]+)?$")
errors = []


def error(where, message):
    errors.append(f"{where}: {message}")


def tracked_files():
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, check=True, capture_output=True, text=True)
    return [f for f in out.stdout.splitlines() if (ROOT / f).exists()]


def library_sources():
    text = (ROOT / "cmake" / "imucal_parts.cmake").read_text()
    return sorted(s for m in re.finditer(r"^set\(IMUCAL_PART_SOURCES_\w+ ([^)]*)\)", text, re.M)
                  for s in m.group(1).split())


def properties(path):
    values = {}
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if "=" not in line:
            error(path.name, f"line {n} is not key=value")
            continue
        key, value = line.split("=", 1)
        values[key.strip()] = value.strip()
    return values


# --- versions -------------------------------------------------------------------------------
def check_versions():
    found = {}
    m = re.search(r"^project\(imucal VERSION (\S+)", (ROOT / "CMakeLists.txt").read_text(), re.M)
    found["CMakeLists.txt project(VERSION)"] = m.group(1) if m else None
    header = (ROOT / "include" / "imucal" / "version.hpp").read_text()
    parts = [re.search(rf"#define IMUCAL_VERSION_{p} (\d+)", header) for p in
             ("MAJOR", "MINOR", "PATCH")]
    found["version.hpp MAJOR.MINOR.PATCH"] = (".".join(p.group(1) for p in parts)
                                              if all(parts) else None)
    m = re.search(r'#define IMUCAL_VERSION_STRING "([^"]+)"', header)
    found["version.hpp IMUCAL_VERSION_STRING"] = m.group(1) if m else None
    found["library.json"] = json.loads((ROOT / "library.json").read_text()).get("version")
    m = re.search(r'^version:\s*"?([^"\s]+)"?', (ROOT / "idf_component.yml").read_text(), re.M)
    found["idf_component.yml"] = m.group(1) if m else None
    found["library.properties"] = properties(ROOT / "tools/arduino/library.properties").get(
        "version")
    m = re.search(r"^## \[?(\d+\.\d+\.\d+)\]?", (ROOT / "CHANGELOG.md").read_text(), re.M)
    found["CHANGELOG.md newest entry"] = m.group(1) if m else None
    if len(set(found.values())) != 1 or None in found.values():
        error("versions", "they differ: " + ", ".join(f"{k} {v}" for k, v in found.items()))
    else:
        print(f"versions: {found['library.json']} in all {len(found)} places")


# --- PlatformIO -------------------------------------------------------------------------------
PIO_FIELDS = {"name", "version", "description", "keywords", "homepage", "repository", "authors",
              "license", "frameworks", "platforms", "headers", "examples", "dependencies",
              "export", "scripts", "build", "downloadUrl"}
PIO_AUTHOR = {"name", "email", "url", "maintainer"}
PIO_REPOSITORY = {"type", "url", "branch"}
PIO_DEPENDENCY = {"owner", "name", "version", "frameworks", "platforms", "authors"}
PIO_EXPORT = {"include", "exclude"}
PIO_EXAMPLE = {"name", "base", "files"}
PIO_BUILD = {"flags", "unflags", "includeDir", "srcDir", "srcFilter", "extraScript",
             "libArchive", "libLDFMode", "libCompatMode", "builder"}
PIO_SCRIPTS = {"postinstall", "preuninstall"}


def as_list(value):
    return value if isinstance(value, list) else [v.strip() for v in str(value).split(",")]


def keys_within(where, obj, allowed):
    if not isinstance(obj, dict):
        error(where, f"expected an object, found {type(obj).__name__}")
        return
    for key in obj:
        if key not in allowed:
            error(where, f"unknown field {key!r} (the format has {', '.join(sorted(allowed))})")


def glob_files(base, pattern, files):
    """Repository files under base matched by a PlatformIO/SCons or manifest glob pattern."""
    pattern = pattern.rstrip("/")
    rel = [str(pathlib.PurePosixPath(f).relative_to(base)) for f in files
           if base == "." or f.startswith(base.rstrip("/") + "/")] if base != "." else files
    out = set()
    for f in rel:
        if fnmatch.fnmatch(f, pattern) or f.startswith(pattern + "/") or \
                fnmatch.fnmatch(f, pattern + "/*"):
            out.add(f)
    return out


def source_filter(files, src_dir, filters):
    """The files a srcFilter selects, applied in order as PlatformIO does (+ adds, - removes)."""
    items = filters if isinstance(filters, list) else re.findall(r"[+-]<[^>]*>", filters)
    selected = set()
    for item in items:
        m = re.fullmatch(r"([+-])<([^>]*)>", item.strip())
        if not m:
            error("library.json build.srcFilter", f"{item!r} is not +<pattern> or -<pattern>")
            continue
        matched = glob_files(src_dir, m.group(2), files)
        if m.group(1) == "+":
            if not matched:
                error("library.json build.srcFilter", f"{item} matches no file")
            selected |= matched
        else:
            selected -= matched
    return selected


def check_platformio(files):
    where = "library.json"
    data = json.loads((ROOT / "library.json").read_text())
    keys_within(where, data, PIO_FIELDS)
    for required in ("name", "version"):
        if required not in data:
            error(where, f"no {required}")
    if not re.fullmatch(r"[^:;/,@<>]+", data.get("name", "")) or len(data.get("name", "")) > 100:
        error(where, "name: 1-100 characters, none of :;/,@<>")
    if not SEMVER.match(str(data.get("version", ""))):
        error(where, f"version {data.get('version')!r} is not semantic")
    if len(data.get("description", "")) > 1000:
        error(where, "description: at most 1000 characters")
    for k in as_list(data.get("keywords", [])):
        if not re.fullmatch(r"[a-z\d\-+. ]{1,50}", k):
            error(where, f"keyword {k!r}: only [a-z0-9-+. ], at most 50")
    for field in ("frameworks", "platforms"):
        for v in as_list(data.get(field, [])):
            if not re.fullmatch(r"[a-z\d\-_]+|\*", v):
                error(where, f"{field} {v!r}: only [a-z0-9-_*]")
    if data.get("license") not in (None, "MIT"):
        error(where, f"license {data.get('license')!r}: imucal is MIT")
    authors = data.get("authors", [])
    for a in authors if isinstance(authors, list) else [authors]:
        keys_within(f"{where} authors", a, PIO_AUTHOR)
        if not a.get("name"):
            error(where, "an author without a name")
    if "repository" in data:
        keys_within(f"{where} repository", data["repository"], PIO_REPOSITORY)
        if data["repository"].get("type") not in ("git", "hg", "svn"):
            error(where, "repository.type: git, hg or svn")
    for d in data.get("dependencies", []):
        keys_within(f"{where} dependencies", d, PIO_DEPENDENCY)
    if "scripts" in data:
        keys_within(f"{where} scripts", data["scripts"], PIO_SCRIPTS)
    keys_within(f"{where} export", data.get("export", {}), PIO_EXPORT)
    for kind in ("include", "exclude"):
        for pattern in data.get("export", {}).get(kind, []):
            if not glob_files(".", pattern, files):
                error(f"{where} export.{kind}", f"{pattern!r} matches no file")
    for ex in data.get("examples", []):
        keys_within(f"{where} examples", ex, PIO_EXAMPLE)
        if not re.fullmatch(r"[a-zA-Z\d\-_/]{1,100}", ex.get("name", "")):
            error(where, f"example name {ex.get('name')!r}: only [a-zA-Z0-9-_/]")
        for f in ex.get("files", []):
            if not (ROOT / ex.get("base", "") / f).is_file():
                error(where, f"example file {ex.get('base')}/{f} does not exist")
    build = data.get("build", {})
    keys_within(f"{where} build", build, PIO_BUILD)
    src_dir = build.get("srcDir", "src")
    include_dir = build.get("includeDir", "include")
    for field, path in (("srcDir", src_dir), ("includeDir", include_dir)):
        if not (ROOT / path).is_dir():
            error(where, f"build.{field} {path!r} is not a folder")
    flags = " ".join(as_list(build.get("flags", []))) if isinstance(build.get("flags"), list) \
        else str(build.get("flags", ""))
    for folder in re.findall(r"-I\s*(\S+)", flags):
        if not (ROOT / folder).is_dir():
            error(where, f"build.flags -I {folder}: not a folder")
    if "-std=gnu++17" not in flags and "-std=c++17" not in flags:
        error(where, "build.flags: the library's sources need -std=gnu++17")
    for header in as_list(data.get("headers", [])):
        if not (ROOT / include_dir / header).is_file():
            error(where, f"header {header} is not in {include_dir}/")
    selected = source_filter(files, src_dir, build.get("srcFilter", ["+<*>"]))
    selected = sorted(str(pathlib.PurePosixPath(src_dir) / f) if src_dir != "." else f
                      for f in selected if f.endswith((".c", ".cpp", ".cc", ".S")))
    if selected != library_sources():
        error(where, f"build.srcFilter compiles {selected}, not the library's sources "
                     f"{library_sources()}")
    else:
        print(f"platformio: library.json's fields are PlatformIO's; the source filter compiles "
              f"the {len(selected)} library sources and nothing else")


# --- ESP-IDF ------------------------------------------------------------------------------------
IDF_FIELDS = {"name", "version", "targets", "maintainers", "description", "license", "tags",
              "dependencies", "files", "examples", "url", "repository", "documentation",
              "issues", "discussion", "repository_info"}
IDF_DEPENDENCY = {"version", "public", "path", "git", "registry_url", "service_url", "rules",
                  "matches", "override_path", "require", "pre_release"}
IDF_FILES = {"use_gitignore", "include", "exclude"}
IDF_TARGETS = {"esp32", "esp32s2", "esp32c3", "esp32s3", "esp32c2", "esp32c5", "esp32c6",
               "esp32c61", "esp32h2", "esp32h21", "esp32h4", "esp32p4", "linux"}
SLUG = r"[a-zA-Z\d]+(?:(?:[_-](?![_-]+))|(?:[a-zA-Z\d]))*[a-zA-Z\d]+"


def glob_match(path, pattern):
    """A path glob as the component manager applies it: ** spans folders, * and ? do not."""
    regex = ""
    i = 0
    while i < len(pattern):
        if pattern.startswith("**/", i):
            regex, i = regex + "(?:.*/)?", i + 3
        elif pattern.startswith("**", i):
            regex, i = regex + ".*", i + 2
        else:
            c = pattern[i]
            regex += "[^/]*" if c == "*" else "[^/]" if c == "?" else re.escape(c)
            i += 1
    return re.fullmatch(regex, path) is not None


def check_esp_idf(files):
    import yaml  # Debian's python3-yaml
    where = "idf_component.yml"
    data = yaml.safe_load((ROOT / "idf_component.yml").read_text())
    keys_within(where, data, IDF_FIELDS)
    if not re.fullmatch(r"\d+\.\d+\.\d+(?:[-+~][0-9A-Za-z.~-]+)?", str(data.get("version", ""))):
        error(where, f"version {data.get('version')!r}")
    if data.get("license") != "MIT":
        error(where, "license: MIT (an SPDX identifier)")
    for tag in data.get("tags", []):
        if not re.fullmatch(r"[A-Za-z0-9_\-]{3,32}", tag):
            error(where, f"tag {tag!r}: 3-32 of [A-Za-z0-9_-]")
    for target in data.get("targets", []):
        if target not in IDF_TARGETS:
            error(where, f"unknown target {target!r}")
    for name, dep in data.get("dependencies", {}).items():
        if not re.fullmatch(rf"(?:{SLUG}/{SLUG})|(?:{SLUG})", name) or "__" in name:
            error(where, f"dependency name {name!r}")
        if isinstance(dep, dict):
            keys_within(f"{where} dependencies.{name}", dep, IDF_DEPENDENCY)
            if dep.get("require") not in (None, "public", "private", "no", False):
                error(where, f"dependencies.{name}.require: public, private or no")
        elif not isinstance(dep, str):
            error(where, f"dependencies.{name}: a version string or an object")
    keys_within(f"{where} files", data.get("files", {}), IDF_FILES)
    for kind in ("include", "exclude"):
        for pattern in data.get("files", {}).get(kind, []):
            if not any(glob_match(f, pattern) for f in files):
                error(f"{where} files.{kind}", f"{pattern!r} matches no file")
    out = subprocess.run(["cmake", f"-DIMUCAL_SOURCE_DIR={ROOT}", "-P",
                          str(ROOT / "tests" / "manifests" / "esp_idf_register.cmake")],
                         capture_output=True, text=True)
    if out.returncode != 0:
        error("CMakeLists.txt under ESP_PLATFORM", out.stdout + out.stderr)
        return
    registered = dict(line[3:].split(" ", 1) for line in out.stdout.splitlines()
                      if line.startswith("-- "))
    srcs = sorted(registered.get("SRCS", "").split(";"))
    dirs = registered.get("INCLUDE_DIRS", "").split(";")
    if srcs != library_sources():
        error("CMakeLists.txt under ESP_PLATFORM", f"registers {srcs}")
    for d in dirs:
        if not (ROOT / d).is_dir():
            error("CMakeLists.txt under ESP_PLATFORM", f"include folder {d} does not exist")
    if "include" not in dirs:
        error("CMakeLists.txt under ESP_PLATFORM", "include/ is not an include folder")
    print(f"esp-idf: idf_component.yml's fields are the component manager's; CMakeLists.txt "
          f"registers the {len(srcs)} library sources and {', '.join(dirs)}")


# --- Arduino ------------------------------------------------------------------------------------
ARDUINO_FIELDS = {"name", "version", "author", "maintainer", "sentence", "paragraph", "category",
                  "url", "architectures", "depends", "dot_a_linkage", "includes", "precompiled",
                  "ldflags"}
ARDUINO_REQUIRED = {"name", "version", "author", "maintainer", "sentence", "paragraph",
                    "category", "architectures"}
ARDUINO_CATEGORIES = {"Display", "Communication", "Signal Input/Output", "Sensors",
                      "Device Control", "Timing", "Data Storage", "Data Processing", "Other"}


def check_arduino():
    where = "tools/arduino/library.properties"
    data = properties(ROOT / where)
    for key in data:
        if key not in ARDUINO_FIELDS:
            error(where, f"unknown field {key!r}")
    for key in ARDUINO_REQUIRED - set(data):
        error(where, f"no {key}")
    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9 ._-]*", data.get("name", "")):
        error(where, "name: letters, digits, space, . _ -, starting with a letter or digit")
    if not SEMVER.match(data.get("version", "")):
        error(where, f"version {data.get('version')!r} is not semantic")
    if data.get("category") not in ARDUINO_CATEGORIES:
        error(where, f"category {data.get('category')!r} is not one of the format's")
    for header in as_list(data.get("includes", "")):
        if header and not (ROOT / "include" / header).is_file():
            error(where, f"includes {header}: not a header of the library")
    if not (ROOT / "examples" / "arduino").is_dir():
        error(where, "no example sketch under examples/arduino")
    print(f"arduino: library.properties' fields are the Arduino library format's "
          f"(category {data.get('category')}, depends {data.get('depends')})")


def main():
    checks = sys.argv[1:] or ["versions", "platformio", "esp-idf", "arduino"]
    files = tracked_files()
    for check in checks:
        {"versions": check_versions, "platformio": lambda: check_platformio(files),
         "esp-idf": lambda: check_esp_idf(files), "arduino": check_arduino}[check]()
    if errors:
        print("\n".join(errors))
        return 1
    print("manifests: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
