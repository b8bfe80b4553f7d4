-- Drives headless Neovim (0.7 and later) as an editor user would, for test_neovim.py:
-- open the domain, attach tmpc lsp, inject an error by an edit, wait for its diagnostic,
-- hover on a geometric predicate. Writes what it saw as JSON to $TMPC_NVIM_OUT and quits.
local out_path = os.getenv("TMPC_NVIM_OUT")
local seen = { steps = {} }

local function finish()
  local f = io.open(out_path, "w")
  f:write(vim.fn.json_encode(seen))
  f:close()
  vim.cmd("qa!")
end

local function step(name) table.insert(seen.steps, name) end

local ok, err = pcall(function()
  vim.cmd("edit " .. vim.fn.fnameescape(os.getenv("TMPC_NVIM_FILE")))
  local buf = vim.api.nvim_get_current_buf()
  local id = vim.lsp.start_client({
    name = "tmpc",
    cmd = vim.fn.json_decode(os.getenv("TMPC_NVIM_CMD")),
    root_dir = os.getenv("TMPC_NVIM_ROOT"),
  })
  vim.lsp.buf_attach_client(buf, id)
  local client = vim.lsp.get_client_by_id(id)
  step("attached")
  vim.wait(30000, function() return client.initialized end, 20)
  seen.initialized = client.initialized and true or false
  -- the clean file: wait for its first publish (no errors expected)
  vim.wait(3000, function() return false end, 200)
  seen.before = #vim.diagnostic.get(buf, { severity = vim.diagnostic.severity.ERROR })
  -- inject an error as a user would: an edit in pick's precondition
  local lines = vim.api.nvim_buf_get_lines(buf, 0, -1, false)
  for i, line in ipairs(lines) do
    local s, e = line:find("(reach ?g ?c))", 1, true)
    if s then
      vim.api.nvim_buf_set_text(buf, i - 1, s, i - 1, s + 5, { "reachh" })
      seen.edited_line = i
      break
    end
  end
  step("edited")
  vim.wait(15000, function()
    return #vim.diagnostic.get(buf, { severity = vim.diagnostic.severity.ERROR }) > 0
  end, 20)
  seen.diagnostics = {}
  for _, d in ipairs(vim.diagnostic.get(buf)) do
    table.insert(seen.diagnostics, { lnum = d.lnum, col = d.col, message = d.message,
      code = d.code or (d.user_data and d.user_data.lsp and d.user_data.lsp.code) })
  end
  -- hover on `near` inside reach's :semantics
  for i, line in ipairs(vim.api.nvim_buf_get_lines(buf, 0, -1, false)) do
    local s = line:find("(reach ?g - gripper", 1, true)
    if s then
      vim.api.nvim_win_set_cursor(0, { i, s + 1 })
      break
    end
  end
  local params = vim.lsp.util.make_position_params()
  local reply = client.request_sync("textDocument/hover", params, 20000, buf)
  seen.hover = reply and reply.result and reply.result.contents or vim.NIL
  seen.hover_error = reply and reply.err and tostring(reply.err.message) or vim.NIL
  step("hovered")
end)
seen.ok = ok
seen.error = ok and vim.NIL or tostring(err)
finish()
