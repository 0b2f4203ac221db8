"""The reports people open, opened in a real browser (Debian's chromium, headless, driven by
chromedriver through python3-selenium), every page in one browser session:

- the golden review pages: `penumbra-golden check --case indoor --report DIR` writes them (the
  index of the cases and the case's page: the comparison table and the images);
- penumbra-bench's report.md, drawn again (`--replot`, with `--texel-rate`) from the checked-in
  lavapipe run (docs/data/bench/lavapipe/shipped.csv and texel_rate.json);
- penumbra-tune's frontier.png, drawn again (`--replot`) from a checked-in run (docs/data/tune);
- the measured reports checked in under docs/: the bench's and the other tools' reports under
  docs/data/, and docs/tuning.md, docs/performance.md and docs/accuracy.md, which show the tune's
  and the bench's results.

A Markdown page is rendered as GitHub renders it (cmark-gfm with GitHub's extensions) into a
page whose <base> is the Markdown file's folder, so its relative images and links resolve as
they do on GitHub. A page fails, naming the report and the element, when an <img> did not load
(complete and naturalWidth > 0) or is cut short (the browser makes no bitmap of it), a local file
that an href or src names is missing, a <table> is not displayed, has no height or no body row,
a Markdown table did not become a <table>, or the page logged an error (an uncaught exception, a
resource that failed to load).

The checker is checked too: broken copies of a golden page (a PNG deleted, the table emptied, a
script error) and of the bench report (a PNG that is not one, a PNG cut in half, a table whose
delimiter row is gone) must each fail with the element named.

Chromium runs with a private profile in a temporary folder (and --no-sandbox as root). Nothing
here waits on a clock for its verdict: a watchdog only ends a run that hangs.
Usage: reports_browser_test.py SOURCE_DIR PENUMBRA_GOLDEN WORK_DIR"""
import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse
import urllib.request

source, golden_tool, work = (os.path.abspath(p) for p in sys.argv[1:4])
TOOLS = os.path.join(source, "tools")
WATCHDOG_S = 150  # the CTest TIMEOUT is 180 s
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
started = time.monotonic()

# Everything this test starts (the tools, chromedriver, chromium) is its descendant and, where
# it can lead a session of its own, shares its process group: the watchdog ends them all.
try:
    os.setsid()
    own_group = True
except OSError:
    own_group = False


def descendants(pid):
    children = {}
    for entry in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{entry}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(ppid, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def kill_descendants():
    for pid in descendants(os.getpid()):
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass


def watchdog():
    print(f"FAIL reports_browser_test: still running after {WATCHDOG_S} s; killing it and "
          "everything it started", flush=True)
    try:
        kill_descendants()
        if "profile" in globals():  # the browser's profile folder
            shutil.rmtree(profile, ignore_errors=True)
        if own_group:
            os.killpg(0, signal.SIGKILL)
    finally:
        os._exit(1)


timer = threading.Timer(WATCHDOG_S, watchdog)
timer.daemon = True
timer.start()

missing = [p for p in (CHROMIUM, CHROMEDRIVER, "/usr/bin/cmark-gfm") if not os.path.exists(p)]
try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
except ImportError:
    missing.append("python3-selenium")
if missing:
    print("FAIL missing " + ", ".join(missing) + " (Debian's chromium, chromium-driver, "
          "cmark-gfm and python3-selenium: .ci/install-deps.sh installs them)")
    sys.exit(1)

shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []


# ---- the reports, generated while the browser starts -----------------------------------------
def start(name, args, env=None):
    log = open(os.path.join(work, name + ".log"), "w")
    return name, subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, env=env,
                                  cwd=work), log


golden_dir = os.path.join(work, "golden")
jobs = [start("penumbra-golden", [golden_tool, "check", "--case", "indoor", "--report",
                                  golden_dir],
              dict(os.environ, PENUMBRA_GOLDEN_DIR=os.path.join(source, "tests", "golden")))]

# penumbra-bench --replot reads DIR/bench.json: the checked-in run's rows, typed as the bench
# writes them.
bench_dir = os.path.join(work, "bench")
os.makedirs(bench_dir)
bench_data = os.path.join(source, "docs", "data", "bench", "lavapipe")
TEXT = {"scene", "config", "sets", "light", "device", "driver", "commit", "scene_hash", "filter",
        "resolve_pass", "passes", "flicker"}


def typed(key, text):
    if key in TEXT:
        return text
    if text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


with open(os.path.join(bench_data, "shipped.csv"), newline="") as f:
    rows = [{k: typed(k, v) for k, v in r.items()} for r in csv.DictReader(f)]
meta = {"device": rows[0]["device"], "driver": rows[0]["driver"], "commit": rows[0]["commit"],
        "frames": 10, "size": f"{rows[0]['width']}x{rows[0]['height']}"}
with open(os.path.join(bench_dir, "bench.json"), "w") as f:
    json.dump({"meta": meta, "rows": rows}, f)
jobs.append(start("penumbra-bench", [sys.executable, os.path.join(TOOLS, "penumbra-bench"),
                                     "--replot", bench_dir, "--texel-rate",
                                     os.path.join(bench_data, "texel_rate.json")]))
frontier = os.path.join(work, "tune", "frontier.png")
os.makedirs(os.path.dirname(frontier))
jobs.append(start("penumbra-tune", [sys.executable, os.path.join(TOOLS, "penumbra-tune"),
                                    "--replot",
                                    os.path.join(source, "docs", "data", "tune",
                                                 "default-lavapipe"), "--out", frontier]))

# ---- Markdown as GitHub renders it ------------------------------------------------------------
DELIMITER = re.compile(r"^\s*\|?\s*:?-+:?\s*(\|\s*:?-+:?\s*)*\|?\s*$")


def markdown_tables(text):
    """The tables a Markdown text holds: a row of cells followed by a delimiter row, outside
    fenced code."""
    lines, count, fenced = text.splitlines(), 0, False
    for i, line in enumerate(lines):
        if re.match(r"\s{0,3}(```|~~~)", line):
            fenced = not fenced
        if (not fenced and "|" in line and not DELIMITER.match(line) and i + 1 < len(lines)
                and "-" in lines[i + 1] and DELIMITER.match(lines[i + 1])):
            count += 1
    return count


def render_markdown(md, html_dir):
    """MD as an HTML page in HTML_DIR whose links resolve against MD's own folder; returns the
    page and the number of tables the Markdown holds."""
    with open(md, encoding="utf-8") as f:
        text = f.read()
    r = subprocess.run(["/usr/bin/cmark-gfm", "--unsafe", "-e", "table", "-e", "autolink",
                        "-e", "strikethrough", "-e", "tagfilter", md],
                       capture_output=True, text=True, timeout=30)
    if r.returncode != 0:
        failures.append(f"{md}: cmark-gfm exited {r.returncode}: {r.stderr}")
    base = urllib.request.pathname2url(os.path.dirname(os.path.abspath(md))) + "/"
    os.makedirs(html_dir, exist_ok=True)
    page = os.path.join(html_dir, re.sub(r"[^\w.-]", "_", os.path.relpath(md, "/")) + ".html")
    with open(page, "w", encoding="utf-8") as f:
        f.write(f'<!DOCTYPE html>\n<html><head><meta charset="utf-8"><base href="file://{base}">'
                f"<title>{os.path.basename(md)}</title></head><body>\n{r.stdout}</body></html>\n")
    return page, markdown_tables(text)


# ---- the browser ------------------------------------------------------------------------------
profile = tempfile.mkdtemp(prefix="penumbra-chromium-")
options = webdriver.ChromeOptions()
options.binary_location = CHROMIUM
for arg in ("--headless=new", f"--user-data-dir={profile}", "--disable-gpu",
            "--disable-dev-shm-usage", "--no-first-run", "--disable-extensions",
            "--window-size=1280,1000"):
    options.add_argument(arg)
if os.geteuid() == 0:
    options.add_argument("--no-sandbox")
options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
service = Service(CHROMEDRIVER, log_file=open(os.path.join(work, "chromedriver.log"), "w"))
driver = webdriver.Chrome(service=service, options=options)
print(f"browser started at {time.monotonic() - started:.1f} s")
driver.set_page_load_timeout(30)
driver.set_script_timeout(10)

INSPECT = """
const out = {images: [], refs: [], tables: [], pipes: []};
for (const img of document.images)
  out.images.push({src: img.getAttribute('src'), ok: img.complete && img.naturalWidth > 0});
for (const el of document.querySelectorAll('[href]:not(base), [src]')) {
  const url = el.href || el.src;
  if (typeof url === 'string' && url.startsWith('file:'))
    out.refs.push({tag: el.tagName.toLowerCase(), attr: el.hasAttribute('href') ? 'href' : 'src',
                   value: el.getAttribute('href') || el.getAttribute('src'), url: url});
}
document.querySelectorAll('table').forEach((t, i) => {
  const style = getComputedStyle(t);
  const body = Array.from(t.rows).filter(r => r.querySelector('td'));
  out.tables.push({index: i + 1, display: style.display, visibility: style.visibility,
                   height: t.getBoundingClientRect().height, body: body.length,
                   shown: body.filter(r => r.getBoundingClientRect().height > 0).length,
                   head: t.rows.length ? t.rows[0].innerText.replace(/\\s+/g, ' ').slice(0, 60)
                                       : ''});
});
for (const p of document.querySelectorAll('p'))
  if (/^\\|.*\\|/.test(p.textContent.trim())) out.pipes.push(p.textContent.trim().slice(0, 70));
return out;
"""

DECODE = """
const done = arguments[arguments.length - 1];
Promise.all(Array.from(document.images).map(img =>
  img.complete && img.naturalWidth > 0
      ? createImageBitmap(img).then(b => { b.close(); return 'ok'; }, e => String(e))
      : 'not loaded')).then(done);
"""


def local_path(url):
    parsed = urllib.parse.urlparse(url)
    return urllib.request.url2pathname(parsed.path)


def check_page(name, path, md_tables=None, min_tables=0):
    """The problems of one page, each naming the report and the element."""
    problems = []
    driver.get_log("browser")  # what earlier pages logged
    driver.get("file://" + urllib.request.pathname2url(os.path.abspath(path)))
    found = driver.execute_script(INSPECT)
    # A loaded image may still be cut short (the browser shows what it has): a bitmap of it,
    # which the browser makes only from a wholly decoded image, tells.
    decoded = driver.execute_async_script(DECODE)
    for img, bitmap in zip(found["images"], decoded):
        if not img["ok"]:
            problems.append(f'{name}: <img src="{img["src"]}"> did not load')
        elif bitmap != "ok":
            problems.append(f'{name}: <img src="{img["src"]}"> is not a whole image ({bitmap})')
    seen = set()
    for ref in found["refs"]:
        target = local_path(ref["url"])
        if target not in seen and not os.path.exists(target):
            problems.append(f'{name}: <{ref["tag"]} {ref["attr"]}="{ref["value"]}">: no file '
                            f"{target}")
        seen.add(target)
    for t in found["tables"]:
        what = f'{name}: table {t["index"]} ("{t["head"]}")'
        if t["display"] == "none" or t["visibility"] == "hidden" or t["height"] <= 0:
            problems.append(f'{what} is not rendered (display {t["display"]}, visibility '
                            f'{t["visibility"]}, height {t["height"]})')
        elif t["body"] == 0 or t["shown"] == 0:
            problems.append(f'{what} has no rendered rows ({t["body"]} body rows, '
                            f'{t["shown"]} shown)')
    if md_tables is not None and len(found["tables"]) < md_tables:
        problems.append(f'{name}: {md_tables} tables in the Markdown, {len(found["tables"])} '
                        "rendered" + "".join(f'; not a table: "{p}"' for p in found["pipes"]))
    elif found["pipes"]:
        problems += [f'{name}: table text outside a table: "{p}"' for p in found["pipes"]]
    if len(found["tables"]) < min_tables:
        problems.append(f"{name}: {len(found['tables'])} tables, expected at least {min_tables}")
    for entry in driver.get_log("browser"):
        if entry.get("level") == "SEVERE":
            problems.append(f"{name}: the page logged an error: {entry.get('message')}")
    return problems, found


def check_pages(pages):
    """Opens each page (following the golden index to the case pages it links), records its
    problems; returns how many pages it opened."""
    count = 0
    for name, page, md_tables, min_tables in pages:
        problems, found = check_page(name, page, md_tables, min_tables)
        failures.extend(problems)
        count += 1
        print(f"{name}: {len(found['images'])} images, {len(found['tables'])} tables, "
              f"{len(found['refs'])} local references{'' if not problems else ', FAILED'}")
        if name == "golden review index.html":  # the case pages the index links to
            for ref in found["refs"]:
                target = local_path(ref["url"])
                if target.endswith(".html") and os.path.isfile(target):
                    case = os.path.basename(os.path.dirname(target))
                    pages.append((f"golden review {case}/index.html", target, None, 1))
    return count


try:
    # The checked-in reports first, while the tools write theirs.
    html_dir = os.path.join(work, "html")
    docs = os.path.join(source, "docs")
    checked_in = [os.path.join(docs, d) for d in ("tuning.md", "performance.md", "accuracy.md")]
    for root, _, files in sorted(os.walk(os.path.join(docs, "data"))):
        checked_in += [os.path.join(root, f) for f in sorted(files) if f.endswith(".md")]
    pages = []  # (report, page file, tables in its Markdown, least tables)
    for md in checked_in:
        page, n = render_markdown(md, html_dir)
        pages.append((os.path.relpath(md, source), page, n, 0))
    checked = check_pages(pages)
    print(f"{checked} checked-in pages at {time.monotonic() - started:.1f} s")

    for name, proc, log in jobs:
        try:
            rc = proc.wait(timeout=120)
        except subprocess.TimeoutExpired:
            proc.kill()
            rc = "killed after 120 s"
        log.close()
        with open(log.name) as f:
            text = f.read()
        # penumbra-golden check exits 1 when the case differs from its golden (GoldenFrame.*
        # reports that); its pages are written all the same.
        differs = name == "penumbra-golden" and rc == 1 and "indoor: FAILED" in text
        if rc != 0 and not differs:
            failures.append(f"{name} exited {rc}:\n{text[-3000:]}")
        elif differs:
            print(f"note: the indoor case differs from its golden:\n{text[-1500:]}")
    print(f"reports written at {time.monotonic() - started:.1f} s")

    generated = []
    golden_index = os.path.join(golden_dir, "index.html")
    if os.path.isfile(golden_index):
        generated.append(("golden review index.html", golden_index, None, 0))
    else:
        failures.append(f"penumbra-golden check wrote no {golden_index}")
    bench_report = os.path.join(bench_dir, "report.md")
    if os.path.isfile(bench_report):
        page, n = render_markdown(bench_report, html_dir)
        generated.append(("penumbra-bench report.md", page, n, 1))
    else:
        failures.append(f"penumbra-bench --replot wrote no {bench_report}")
    if os.path.isfile(frontier):
        generated.append(("penumbra-tune frontier.png", frontier, None, 0))
    else:
        failures.append(f"penumbra-tune --replot wrote no {frontier}")
    checked += check_pages(generated)
    pages += generated
    if checked < 4 + len(checked_in):  # the index, its case page, the bench and the tune
        failures.append(f"only {checked} pages checked: the golden index linked no case page")

    print(f"{checked} pages checked at {time.monotonic() - started:.1f} s")
    # ---- the checker, checked: broken copies must fail, naming what broke --------------------
    case_page = next((p for n, p, _, _ in pages if n.startswith("golden review ")
                      and n != "golden review index.html"), None)
    if case_page:
        broken = os.path.join(work, "broken-golden")
        shutil.copytree(os.path.dirname(case_page), broken)
        with open(os.path.join(broken, "index.html")) as f:
            html = f.read()
        pngs = re.findall(r'<img src="([^"]+\.png)"', html) or ["(no image on the page)"]
        if os.path.isfile(os.path.join(broken, pngs[0])):
            os.remove(os.path.join(broken, pngs[0]))
        html = re.sub(r"<tr class=[^>]*>.*?</tr>\n", "", html)  # the table's rows
        html = html.replace("</body>", "<script>no_such_function()</script></body>")
        with open(os.path.join(broken, "index.html"), "w") as f:
            f.write(html)
        problems, _ = check_page("broken golden page", os.path.join(broken, "index.html"),
                                 None, 1)
        for want in (f'<img src="{pngs[0]}"> did not load', f'<a href="{pngs[0]}">: no file',
                     "has no rendered rows", "no_such_function"):
            if not any(want in p for p in problems):
                failures.append(f"self-check: a broken golden page was not caught ({want!r} "
                                f"missing from {problems})")
    if os.path.isfile(bench_report):
        broken = os.path.join(work, "broken-bench")
        shutil.copytree(bench_dir, broken)
        with open(os.path.join(broken, "default.png"), "wb") as f:
            f.write(b"not a png")
        with open(os.path.join(broken, "indoor.png"), "rb") as f:
            whole = f.read()
        with open(os.path.join(broken, "indoor.png"), "wb") as f:
            f.write(whole[:len(whole) // 2])  # cut short: the browser shows the top half
        with open(os.path.join(broken, "report.md")) as f:
            text = f.read()
        text = text.replace("|---|---|---|---|---|\n", "", 1)  # the first table's delimiter row
        with open(os.path.join(broken, "report.md"), "w") as f:
            f.write(text)
        page, n = render_markdown(os.path.join(broken, "report.md"),
                                  os.path.join(work, "broken-html"))
        problems, _ = check_page("broken bench report", page, n, 1)
        for want in ('<img src="default.png"> did not load',
                     '<img src="indoor.png"> is not a whole image',
                     'table text outside a table: "| configuration'):
            if not any(want in p for p in problems):
                failures.append(f"self-check: a broken bench report was not caught ({want!r} "
                                f"missing from {problems})")
finally:
    # The browser is ended, not closed: its profile is thrown away, and Chromium's orderly
    # shutdown (driver.quit()) takes a second or more.
    kill_descendants()
    service.process.wait()
    timer.cancel()
    shutil.rmtree(profile, ignore_errors=True)

print(f"{time.monotonic() - started:.1f} s")
for f in failures:
    print("FAIL", f)
sys.exit(1 if failures else 0)
