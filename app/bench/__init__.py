"""The studio's benchmarks and its browser and test harness, beside the app and never imported by it
(tests/test_layers.py): studio.py (`moattn bench --app`), soak.py (`--soak`), exports.py (`--exports`),
browser.py (a real `moattn serve` driven by Playwright in Debian's Chromium), testing.py (tiny models for tests).
The command line that runs them is engine/cli/bench.py."""
