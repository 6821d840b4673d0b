-- Wireshark dissector for the teleop UDP wire protocol, versions 1 and 2 (docs/protocol.md, docs/security.md;
-- proto/ is the contract).
--
--   tshark -X lua_script:deploy/wireshark/teleop.lua -r run.pcapng -Y teleop
--   wireshark -X lua_script:/usr/share/teleop/wireshark/teleop.lua
--   or copy it to ~/.local/lib/wireshark/plugins/ to load it always.
--
-- Recognises a sample on any UDP port by its magic "TLOP" and version (a heuristic dissector), and on the ports of
-- the preference "teleop.ports" (default 47001,47002, the shipped configs') also when it is malformed. Decodes the
-- 36-byte header, dof x (position, velocity, force), the optional energy block (dof x (input, output energy), told
-- by payload_length = 40 x dof) and the CRC-32C, which it verifies (teleop.crc.status) and reports
-- as an expert error when wrong. Header checks mirror the decoder's DecodeStatus order: too short, bad magic, bad
-- version, bad type, bad dof, bad length, bad CRC, non-finite, out of range (teleop.status names the first that fails).
-- Field names: teleop.magic, .version, .type, .role, .flags (.flags.enabled, .fault, .peer_lost, .saturated,
-- .in_fixture, .shutdown, .clutched, .reserved), .dof, .reserved, .payload_length, .seq, .sender_time_ns, .echo_time_ns,
-- .echo_age_ns, .position, .velocity, .force (one per DOF, in order), .input_energy, .output_energy (energy block
-- only, one per DOF), .crc, .crc.computed, .crc.status, .status.
--
-- Version 2 (the authenticated session, link.security.mode psk): the clear parts only, since the samples are
-- encrypted. hello: teleop.ephemeral_key, teleop.hello_timestamp, teleop.handshake_tag; welcome:
-- teleop.ephemeral_key, teleop.handshake_tag; confirm: teleop.session_id,
-- teleop.handshake_tag; frame: teleop.session_id, teleop.frame_seq (64-bit), teleop.ciphertext_length,
-- teleop.ciphertext, teleop.aead_tag. teleop.version, .type (hello 6, welcome 3, confirm 4, frame 5; 2 is the
-- retired hello without timestamp, shown as bad_type), .role and .status (ok, too_short, bad_length, bad_type; sizes
-- as proto/secure_codec.cpp checks them) as for version 1.
-- Nothing here checks a tag: that needs the key.

local teleop = Proto("teleop", "teleop bilateral teleoperation sample")

local kMagic = 0x504F4C54 -- "TLOP" little-endian
local kVersion = 1
local kHeader = 36
local kPerDof = 24
local kEnergyPerDof = 16
local kMaxEnergy = 1e9
local kMaxDof = 6
local kMaxAbsPosition = 10.0
local kMaxAbsVelocity = 100.0
local kMaxAbsForce = 10000.0

local roles = { [0] = "master", [1] = "slave" }
local types = { [1] = "sample", [2] = "retired hello", [3] = "welcome", [4] = "confirm", [5] = "frame", [6] = "hello" }
local crc_status = { [0] = "bad", [1] = "good", [2] = "not checked (truncated)" }

local f = teleop.fields
f.magic = ProtoField.uint32("teleop.magic", "Magic", base.HEX)
f.version = ProtoField.uint8("teleop.version", "Version", base.DEC)
f.type = ProtoField.uint8("teleop.type", "Message type", base.DEC, types)
f.role = ProtoField.uint8("teleop.role", "Sender role", base.DEC, roles)
f.flags = ProtoField.uint8("teleop.flags", "Flags", base.HEX)
f.flag_enabled = ProtoField.bool("teleop.flags.enabled", "Enabled", 8, nil, 0x01)
f.flag_fault = ProtoField.bool("teleop.flags.fault", "Fault (safe state)", 8, nil, 0x02)
f.flag_peer_lost = ProtoField.bool("teleop.flags.peer_lost", "Peer lost", 8, nil, 0x04)
f.flag_saturated = ProtoField.bool("teleop.flags.saturated", "Saturated", 8, nil, 0x08)
f.flag_in_fixture = ProtoField.bool("teleop.flags.in_fixture", "In fixture", 8, nil, 0x10)
f.flag_shutdown = ProtoField.bool("teleop.flags.shutdown", "Shutdown", 8, nil, 0x20)
f.flag_clutched = ProtoField.bool("teleop.flags.clutched", "Clutched", 8, nil, 0x40)
f.flag_reserved = ProtoField.uint8("teleop.flags.reserved", "Reserved bits", base.HEX, nil, 0x80)
f.dof = ProtoField.uint8("teleop.dof", "DOF", base.DEC)
f.reserved = ProtoField.uint8("teleop.reserved", "Reserved", base.HEX)
f.payload_length = ProtoField.uint16("teleop.payload_length", "Payload length", base.DEC)
f.seq = ProtoField.uint32("teleop.seq", "Sequence", base.DEC)
f.sender_time = ProtoField.uint64("teleop.sender_time_ns", "Sender time (ns)", base.DEC)
f.echo_time = ProtoField.uint64("teleop.echo_time_ns", "Echo time (ns, receiver's clock)", base.DEC)
f.echo_age = ProtoField.uint32("teleop.echo_age_ns", "Echo age (ns)", base.DEC)
f.dof_tree = ProtoField.bytes("teleop.dof_entry", "DOF entry")
f.position = ProtoField.double("teleop.position", "Position (m or rad)")
f.velocity = ProtoField.double("teleop.velocity", "Velocity (m/s or rad/s)")
f.force = ProtoField.double("teleop.force", "Force (N or N·m)")
f.energy_tree = ProtoField.bytes("teleop.energy_entry", "Energy entry")
f.input_energy = ProtoField.double("teleop.input_energy", "Input energy (J)")
f.output_energy = ProtoField.double("teleop.output_energy", "Output energy (J)")
f.crc = ProtoField.uint32("teleop.crc", "CRC-32C", base.HEX)
f.crc_computed = ProtoField.uint32("teleop.crc.computed", "CRC-32C computed", base.HEX)
f.crc_status = ProtoField.uint8("teleop.crc.status", "CRC status", base.DEC, crc_status)
f.status = ProtoField.string("teleop.status", "Decode status")
f.ephemeral_key = ProtoField.bytes("teleop.ephemeral_key", "Ephemeral X25519 public key")
f.handshake_tag = ProtoField.bytes("teleop.handshake_tag", "Handshake MAC (HMAC-SHA-512-256)")
f.hello_timestamp = ProtoField.uint64("teleop.hello_timestamp", "Hello timestamp (ns, strictly increasing)", base.DEC)
f.session_id = ProtoField.uint64("teleop.session_id", "Session id", base.HEX)
f.frame_seq = ProtoField.uint64("teleop.frame_seq", "Frame sequence", base.DEC)
f.ciphertext_length = ProtoField.uint16("teleop.ciphertext_length", "Ciphertext length", base.DEC)
f.reserved16 = ProtoField.uint16("teleop.reserved16", "Reserved", base.HEX)
f.ciphertext = ProtoField.bytes("teleop.ciphertext", "Ciphertext (ChaCha20, the version-1 sample)")
f.aead_tag = ProtoField.bytes("teleop.aead_tag", "Poly1305 tag")

local e_bad_crc = ProtoExpert.new("teleop.bad_crc", "CRC-32C mismatch: the receiver rejects this sample (bad_crc)",
  expert.group.CHECKSUM, expert.severity.ERROR)
local e_malformed = ProtoExpert.new("teleop.malformed", "Rejected by the receiver", expert.group.MALFORMED,
  expert.severity.ERROR)
local e_flags = ProtoExpert.new("teleop.state", "Sender state", expert.group.SEQUENCE, expert.severity.NOTE)
teleop.experts = { e_bad_crc, e_malformed, e_flags }

teleop.prefs.ports = Pref.range("UDP ports", "47001,47002", "Ports decoded as teleop even when malformed", 65535)

-- CRC-32C (Castagnoli), reflected polynomial 0x82F63B78, init and final XOR 0xFFFFFFFF (docs/protocol.md).
local crc_table = {}
for i = 0, 255 do
  local c = i
  for _ = 1, 8 do
    if bit32.band(c, 1) ~= 0 then
      c = bit32.bxor(bit32.rshift(c, 1), 0x82F63B78)
    else
      c = bit32.rshift(c, 1)
    end
  end
  crc_table[i] = c
end

local function crc32c(tvb, offset, length)
  local crc = 0xFFFFFFFF
  for i = offset, offset + length - 1 do
    local b = tvb(i, 1):uint()
    crc = bit32.bxor(bit32.rshift(crc, 8), crc_table[bit32.band(bit32.bxor(crc, b), 0xFF)])
  end
  return bit32.bxor(crc, 0xFFFFFFFF)
end

local function finite(x) return x == x and x ~= math.huge and x ~= -math.huge end

local function flag_names(flags)
  local names = {}
  local all = { { 0x01, "enabled" }, { 0x02, "fault" }, { 0x04, "peer-lost" }, { 0x08, "saturated" },
    { 0x10, "in-fixture" }, { 0x20, "shutdown" }, { 0x40, "clutched" } }
  for _, e in ipairs(all) do
    if bit32.band(flags, e[1]) ~= 0 then names[#names + 1] = e[2] end
  end
  return table.concat(names, ",")
end

local function dissect(tvb, pinfo, tree)
  local len = tvb:len()
  pinfo.cols.protocol = "TELEOP"
  local root = tree:add(teleop, tvb(), "teleop sample")
  local status = "ok"
  local function reject(s, item, what)
    if status == "ok" then status = s end
    if item then item:add_proto_expert_info(e_malformed, s .. ": " .. what) end
  end

  if len < kHeader then
    root:add(f.status, "too_short")
    root:add_proto_expert_info(e_malformed, "too_short: " .. len .. " bytes, the header alone is 36")
    pinfo.cols.info = "teleop too short (" .. len .. " bytes)"
    return len
  end
  local magic = tvb(0, 4):le_uint()
  local it_magic = root:add_le(f.magic, tvb(0, 4))
  if magic ~= kMagic then reject("bad_magic", it_magic, "not TLOP") end
  local version = tvb(4, 1):uint()
  local it_version = root:add(f.version, tvb(4, 1))
  if version ~= kVersion then reject("bad_version", it_version, "this dissector knows versions 1 and 2") end
  local mtype = tvb(5, 1):uint()
  local it_type = root:add(f.type, tvb(5, 1))
  if mtype ~= 1 then reject("bad_type", it_type, "unknown message type") end
  local role = tvb(6, 1):uint()
  local it_role = root:add(f.role, tvb(6, 1))
  local flags = tvb(7, 1):uint()
  local ft = root:add(f.flags, tvb(7, 1))
  ft:append_text(" (" .. flag_names(flags) .. ")")
  ft:add(f.flag_enabled, tvb(7, 1))
  ft:add(f.flag_fault, tvb(7, 1))
  ft:add(f.flag_peer_lost, tvb(7, 1))
  ft:add(f.flag_saturated, tvb(7, 1))
  ft:add(f.flag_in_fixture, tvb(7, 1))
  ft:add(f.flag_shutdown, tvb(7, 1))
  ft:add(f.flag_clutched, tvb(7, 1))
  ft:add(f.flag_reserved, tvb(7, 1))
  local dof = tvb(8, 1):uint()
  local it_dof = root:add(f.dof, tvb(8, 1))
  if dof < 1 or dof > kMaxDof then reject("bad_dof", it_dof, "dof must be 1..6") end
  local reserved = tvb(9, 1):uint()
  local it_reserved = root:add(f.reserved, tvb(9, 1))
  local payload = tvb(10, 2):le_uint()
  local it_payload = root:add_le(f.payload_length, tvb(10, 2))
  local seq = tvb(12, 4):le_uint()
  root:add_le(f.seq, tvb(12, 4))
  root:add_le(f.sender_time, tvb(16, 8))
  root:add_le(f.echo_time, tvb(24, 8))
  root:add_le(f.echo_age, tvb(32, 4))

  local n = (dof >= 1 and dof <= kMaxDof) and dof or 0
  local energy = n > 0 and payload == (kPerDof + kEnergyPerDof) * n
  local block = energy and (kPerDof + kEnergyPerDof) or kPerDof
  local need = kHeader + block * n + 4
  if n > 0 and payload ~= kPerDof * n and not energy then
    reject("bad_length", it_payload, "must be 24 x dof (40 x dof with the energy block)")
  end
  if n > 0 and len < need then
    reject("too_short", root, len .. " bytes, dof " .. dof .. " needs " .. need)
    n = math.max(0, math.floor((len - kHeader - 4) / block))
  elseif n > 0 and len > need then
    reject("bad_length", root, (len - need) .. " bytes after the CRC")
  end

  local values_ok = true
  local in_range = true
  local first_position
  for i = 0, n - 1 do
    local base_off = kHeader + kPerDof * i
    if base_off + kPerDof > len then break end
    local sub = root:add(f.dof_tree, tvb(base_off, kPerDof))
    sub:set_text("DOF " .. i)
    local p, v, fo = tvb(base_off, 8):le_float(), tvb(base_off + 8, 8):le_float(), tvb(base_off + 16, 8):le_float()
    sub:add_le(f.position, tvb(base_off, 8))
    sub:add_le(f.velocity, tvb(base_off + 8, 8))
    sub:add_le(f.force, tvb(base_off + 16, 8))
    sub:append_text(string.format(": x %.6g, v %.6g, F %.6g", p, v, fo))
    if i == 0 then first_position = p end
    if not (finite(p) and finite(v) and finite(fo)) then values_ok = false end
    if math.abs(p) > kMaxAbsPosition or math.abs(v) > kMaxAbsVelocity or math.abs(fo) > kMaxAbsForce then
      in_range = false
    end
  end

  for i = 0, (energy and n or 0) - 1 do
    local base_off = kHeader + kPerDof * n + kEnergyPerDof * i
    if base_off + kEnergyPerDof > len then break end
    local sub = root:add(f.energy_tree, tvb(base_off, kEnergyPerDof))
    sub:set_text("Energy DOF " .. i)
    local ein, eout = tvb(base_off, 8):le_float(), tvb(base_off + 8, 8):le_float()
    sub:add_le(f.input_energy, tvb(base_off, 8))
    sub:add_le(f.output_energy, tvb(base_off + 8, 8))
    sub:append_text(string.format(": in %.6g J, out %.6g J", ein, eout))
    if not (finite(ein) and finite(eout)) then values_ok = false end
    if ein < 0 or eout < 0 or ein > kMaxEnergy or eout > kMaxEnergy then in_range = false end
  end

  local crc_off = kHeader + block * n
  if dof >= 1 and dof <= kMaxDof and len >= need then
    local sent = tvb(crc_off, 4):le_uint()
    local computed = crc32c(tvb, 0, crc_off)
    local it_crc = root:add_le(f.crc, tvb(crc_off, 4))
    root:add(f.crc_computed, tvb(crc_off, 4), computed):set_generated()
    if sent == computed then
      root:add(f.crc_status, tvb(crc_off, 4), 1):set_generated()
    else
      root:add(f.crc_status, tvb(crc_off, 4), 0):set_generated()
      it_crc:add_proto_expert_info(e_bad_crc, string.format("CRC-32C is 0x%08X, the bytes give 0x%08X", sent, computed))
      if status == "ok" then status = "bad_crc" end
    end
  else
    root:add(f.crc_status, tvb(0, 0), 2):set_generated()
  end
  if status == "ok" and not values_ok then reject("non_finite", root, "NaN or infinity in a value") end
  if status == "ok" and (not in_range or role > 1 or bit32.band(flags, 0x80) ~= 0 or reserved ~= 0) then
    reject("out_of_range", it_role, "a value, the role, a flag bit or the reserved byte is out of range")
  end
  root:add(f.status, status):set_generated()

  local who = roles[role] or ("role " .. role)
  local info = string.format("%s seq=%u dof=%u [%s]", who, seq, dof, flag_names(flags))
  if first_position then info = info .. string.format(" x0=%.6g m", first_position) end
  if status ~= "ok" then info = info .. " REJECTED: " .. status end
  pinfo.cols.info = info
  root:append_text(string.format(", %s, seq %u", who, seq))
  return len
end

-- Version 2 (docs/protocol.md, "Authenticated session"): 8-byte common header, then by type.
local kKeyExchangeSize = 72 -- welcome
local kHelloSize = 80
local kConfirmSize = 48
local kFrameHeader = 28
local kFrameTag = 16

local function dissect_v2(tvb, pinfo, tree)
  local len = tvb:len()
  pinfo.cols.protocol = "TELEOP"
  local root = tree:add(teleop, tvb(), "teleop secure message")
  root:add_le(f.magic, tvb(0, 4))
  root:add(f.version, tvb(4, 1))
  local mtype = tvb(5, 1):uint()
  local it_type = root:add(f.type, tvb(5, 1))
  local role = tvb(6, 1):uint()
  root:add(f.role, tvb(6, 1))
  root:add(f.reserved, tvb(7, 1))
  local who = roles[role] or ("role " .. role)
  local status = "ok"
  local info
  local function expect(size)
    if len < size then
      status = "too_short"
    elseif len > size then
      status = "bad_length"
    end
    return status == "ok"
  end
  if mtype == 6 then
    if expect(kHelloSize) then
      root:add(f.ephemeral_key, tvb(8, 32))
      root:add_le(f.hello_timestamp, tvb(40, 8))
      root:add(f.handshake_tag, tvb(48, 32))
      info = string.format("%s hello t=%s", who, tostring(tvb(40, 8):le_uint64()))
    end
  elseif mtype == 3 then
    if expect(kKeyExchangeSize) then
      root:add(f.ephemeral_key, tvb(8, 32))
      root:add(f.handshake_tag, tvb(40, 32))
    end
    info = string.format("%s %s", who, types[mtype])
  elseif mtype == 4 then
    if expect(kConfirmSize) then
      root:add_le(f.session_id, tvb(8, 8))
      root:add(f.handshake_tag, tvb(16, 32))
      info = string.format("%s confirm session=0x%s", who, tvb(8, 8):le_uint64():tohex())
    end
  elseif mtype == 5 then
    if len < kFrameHeader + kFrameTag then
      status = "too_short"
    else
      local clen = tvb(24, 2):le_uint()
      if not expect(kFrameHeader + clen + kFrameTag) then
        root:add_le(f.ciphertext_length, tvb(24, 2))
      else
        root:add_le(f.session_id, tvb(8, 8))
        root:add_le(f.frame_seq, tvb(16, 8))
        root:add_le(f.ciphertext_length, tvb(24, 2))
        root:add_le(f.reserved16, tvb(26, 2))
        root:add(f.ciphertext, tvb(kFrameHeader, clen))
        root:add(f.aead_tag, tvb(kFrameHeader + clen, kFrameTag))
        info = string.format("%s frame seq=%s session=0x%s len=%u", who, tostring(tvb(16, 8):le_uint64()),
          tvb(8, 8):le_uint64():tohex(), clen)
      end
    end
  else
    status = "bad_type"
    it_type:add_proto_expert_info(e_malformed, "bad_type: unknown version-2 message type")
  end
  if status ~= "ok" then root:add_proto_expert_info(e_malformed, status .. ": " .. len .. " bytes") end
  root:add(f.status, status):set_generated()
  info = info or string.format("%s %s", who, types[mtype] or ("type " .. mtype))
  if status ~= "ok" then info = info .. " REJECTED: " .. status end
  pinfo.cols.info = info
  root:append_text(string.format(", %s", info))
  return len
end

-- Version 2 when the bytes say so; everything else through the version-1 path (which names what is wrong).
local function dispatch(tvb, pinfo, tree)
  if tvb:len() >= 8 and tvb(0, 4):le_uint() == kMagic and tvb(4, 1):uint() == 2 then
    return dissect_v2(tvb, pinfo, tree)
  end
  return dissect(tvb, pinfo, tree)
end

function teleop.dissector(tvb, pinfo, tree)
  return dispatch(tvb, pinfo, tree)
end

-- Any UDP port: claim a datagram that starts with the magic and a version this dissector knows.
local function heuristic(tvb, pinfo, tree)
  if tvb:len() < 8 or tvb(0, 4):le_uint() ~= kMagic then return false end
  local version = tvb(4, 1):uint()
  if version == 2 then
    dissect_v2(tvb, pinfo, tree)
    return true
  end
  if tvb:len() < kHeader or version ~= kVersion then return false end
  dissect(tvb, pinfo, tree)
  return true
end
teleop:register_heuristic("udp", heuristic)

local registered_ports
local function register_ports()
  local udp = DissectorTable.get("udp.port")
  if registered_ports then udp:remove(registered_ports, teleop) end
  registered_ports = teleop.prefs.ports
  udp:add(registered_ports, teleop)
end
function teleop.prefs_changed() register_ports() end
register_ports()
