#!/usr/bin/env bash
# The README's picture of the report: the default scene run, its report written, and the top of the page
# as headless Chromium shows it at 1280 px (what the browser test checks), halved, into docs/figures/.
# Run after `make env` (or `make test`) has made .venv with Chromium:   bash scripts/report-screenshot.sh
set -euo pipefail
cd "$(dirname "$0")/.."
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
if [ -z "$browser" ]; then
    echo "no headless Chromium on PATH: run scripts/install-chromium.sh" >&2
    exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
.venv/bin/femref run -o "$work/default.h5" >/dev/null
.venv/bin/femref report "$work/default.h5" -o "$work/default.html" >/dev/null
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars --virtual-time-budget=10000 \
    --window-size=1280,1800 --screenshot="$work/page.png" "file://$work/default.html" 2>/dev/null
.venv/bin/python - "$work/page.png" docs/figures/report_default.png <<'EOF'
import sys
from PIL import Image

page = Image.open(sys.argv[1])
page.resize((page.width // 2, page.height // 2), Image.LANCZOS).save(sys.argv[2], optimize=True)
EOF
echo "wrote docs/figures/report_default.png"
