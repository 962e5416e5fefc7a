#!/usr/bin/env bash
# The report's browser test (tests/report/test_report.py::test_browser_renders_the_page) renders
# the HTML report in headless Chromium. Install it when we are root on Debian; otherwise say
# what to do. Never fails the set-up: without Chromium that test is skipped with the reason.
set -u
for name in chromium chromium-browser google-chrome; do
    if command -v "$name" >/dev/null 2>&1; then
        exit 0
    fi
done
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing Chromium for the report's headless-browser test (apt-get install chromium)"
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
        || echo "warning: could not install Chromium; the report's browser test will be skipped"
else
    echo "note: Chromium not found and not installable here (not root, or no apt-get); the report's browser test will be skipped (Debian: sudo apt-get install chromium; or put chromium, chromium-browser or google-chrome on PATH)"
fi
exit 0
