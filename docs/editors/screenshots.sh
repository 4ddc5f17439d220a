#!/usr/bin/env bash
# Remakes the screenshots in docs/editors.md: Neovim (Debian's 0.7) with `lumo lsp` on
# demo/scene.json in a tmux window, its screen captured with colours, turned into HTML by `aha`
# and photographed by headless Chromium.
# Needs: apt-get install neovim aha tmux chromium; LUMO=path/to/lumo (default: lumo on PATH).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
lumo="${LUMO:-$(command -v lumo)}"
work="$(mktemp -d)"
cp -r "$here/demo/." "$work/"
# The demo scene's "$schema" resolves beside it.
"$lumo" schema -o "$work/scene.schema.json"
"$lumo" schema --fragment -o "$work/lib/scene-fragment.schema.json"

shot() { # name, keys typed in Neovim before the completion menu is opened
    tmux kill-session -t lumo-shot 2>/dev/null || true
    tmux new-session -d -s lumo-shot -x 150 -y 20 -e LUMO="$lumo" -e TERM=xterm-256color \
        "cd '$work' && nvim -u init-nvim-0.7.lua scene.json"
    sleep 4 # the server's first diagnostics
    tmux send-keys -t lumo-shot "$2"
    sleep 1
    tmux send-keys -t lumo-shot C-x C-o
    sleep 2
    tmux capture-pane -e -p -t lumo-shot | aha --black --title "lumo lsp in Neovim" \
        | sed 's|<pre>|<pre style="font-family: DejaVu Sans Mono, monospace; font-size: 14px; line-height: 1.25; margin: 8px">|' \
        > "$work/$1.html"
    tmux kill-session -t lumo-shot
    chromium --headless --no-sandbox --disable-gpu --hide-scrollbars \
        --screenshot="$here/$1.png" --window-size=1290,400 "file://$work/$1.html" 2>/dev/null
}

# Diagnostics beside the lines, and the material names offered inside `"material": ""`.
shot nvim-diagnostics-completion '10G$hhi'
# The member names the schema allows in a sphere, offered after `, "`.
shot nvim-member-completion '8G$hhi, "'
rm -rf "$work"
