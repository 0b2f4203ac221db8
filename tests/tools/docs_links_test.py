"""Every relative link and image in README.md and docs/ (history included) resolves: the file
exists, and a #fragment names a heading of it (GitHub's anchors). A moved or renamed doc, or a
heading that changed, fails here naming the file and line of the link. The checker is checked
too: a broken link and a broken anchor in a scratch file must be caught."""
import glob
import os
import re
import sys
import tempfile

root = os.path.abspath(sys.argv[1])
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def slug(heading):
    """GitHub's anchor of a heading: lower case, markup and punctuation dropped, spaces to -."""
    text = re.sub(r"[`*]", "", heading.strip().lower())
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path):
    seen, out, fenced = {}, set(), False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.lstrip().startswith("```"):
                fenced = not fenced
            m = None if fenced else re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
            if m:
                s = slug(m.group(1))
                n = seen.get(s, 0)
                seen[s] = n + 1
                out.add(s if n == 0 else f"{s}-{n}")
    return out


def broken(path):
    """(line, target, why) for each link of a Markdown file that does not resolve."""
    out, fenced = [], False
    with open(path, encoding="utf-8") as f:
        lines = f.readlines()
    for number, line in enumerate(lines, 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        if fenced:
            continue
        for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
                continue
            file, _, fragment = target.partition("#")
            dest = os.path.normpath(os.path.join(os.path.dirname(path), file)) if file else path
            if not os.path.exists(dest):
                out.append((number, target, "no such file"))
            elif fragment and dest.endswith(".md") and fragment not in anchors(dest):
                out.append((number, target, "no such heading"))
    return out


docs = [os.path.join(root, "README.md")] + sorted(
    glob.glob(os.path.join(root, "docs", "**", "*.md"), recursive=True))
failures = []
count = 0
for path in docs:
    for number, target, why in broken(path):
        failures.append(f"{os.path.relpath(path, root)}:{number}: {target}: {why}")
    with open(path, encoding="utf-8") as f:
        count += len(LINK.findall(f.read()))

with tempfile.TemporaryDirectory() as tmp:
    scratch = os.path.join(tmp, "scratch.md")
    with open(scratch, "w") as f:
        f.write("# A `code` heading (issue 1)\n\n[ok](#a-code-heading-issue-1) [ok](scratch.md)\n"
                "[bad](missing.md) [bad](#no-such-heading)\n```\n[in code](missing.md)\n```\n")
    found = [t for _, t, _ in broken(scratch)]
    if found != ["missing.md", "#no-such-heading"]:
        failures.append(f"the checker itself: expected the two broken links, got {found}")

for f in failures:
    print("FAILED:", f)
print(f"{count} links in {len(docs)} files; {len(failures)} broken")
sys.exit(1 if failures else 0)
