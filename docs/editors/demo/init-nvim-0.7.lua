-- Neovim 0.7: start `lumo lsp` for JSON files (0.8 and later: see docs/editors.md).
vim.o.termguicolors = true
vim.o.number = true
vim.o.completeopt = "menuone,noinsert"
vim.cmd("syntax on")
vim.api.nvim_create_autocmd("FileType", {
  pattern = "json",
  callback = function(args)
    local id = vim.lsp.start_client({
      name = "lumo",
      cmd = { vim.env.LUMO or "lumo", "lsp" },
      root_dir = vim.fn.getcwd(),
    })
    vim.lsp.buf_attach_client(args.buf, id)
    vim.bo[args.buf].omnifunc = "v:lua.vim.lsp.omnifunc"
  end,
})
