// teleop-supervise's dashboard (docs/dds.md, "The dashboard"): the WebSocket messages and their escaping, the page's
// requests, the --http endpoint, and the server over real sockets on 127.0.0.1 (page, dygraphs, WebSocket, the
// pair filter, the Origin check, a slow client dropped while publishing goes on).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>
// Asio and property_tree's multi_index trip -Wnull-dereference in their own inlined code (GCC 12), as in
// transport/udp_link.cpp.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/property_tree/json_parser.hpp>
#include <boost/property_tree/ptree.hpp>
#pragma GCC diagnostic pop

#include "teleop/dds/dashboard_messages.hpp"
#include "teleop/dds/dashboard_server.hpp"
#include "teleop/error.hpp"
#include "teleop/json_text.hpp"
#include "teleop/types.hpp"

namespace {

namespace pt = boost::property_tree;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using teleop::JsonString;
using teleop::dds::DashboardServer;

pt::ptree ParseJson(const std::string& text) {
  std::istringstream in(text);
  pt::ptree tree;
  pt::read_json(in, tree);
  return tree;
}

/// What a JSON parser reads back from JsonString(text).
std::string RoundTrip(const std::string& text) {
  return ParseJson("{\"s\":" + JsonString(text) + "}").get<std::string>("s");
}

TEST(JsonText, EscapesQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(JsonString("a\"b\\c"), R"("a\"b\\c")");
  EXPECT_EQ(JsonString("x\ny\tz\r"), R"("x\ny\tz\r")");
  EXPECT_EQ(JsonString(std::string("\x01\x1f\x7f", 3)), R"("\u0001\u001f\u007f")");
  EXPECT_EQ(JsonString(std::string("a\0b", 3)), R"("a\u0000b")");
}

TEST(JsonText, HtmlSpecialCharactersAreEscapedSoNoMarkupSurvives) {
  const std::string attack = "</script><img src=x onerror='alert(1)'>&amp;";
  const std::string encoded = JsonString(attack);
  EXPECT_EQ(encoded.find('<'), std::string::npos) << encoded;
  EXPECT_EQ(encoded.find('>'), std::string::npos) << encoded;
  EXPECT_EQ(encoded.find('&'), std::string::npos) << encoded;
  EXPECT_EQ(encoded.find('\''), std::string::npos) << encoded;
  EXPECT_NE(encoded.find(R"(\u003c/script\u003e)"), std::string::npos) << encoded;
  EXPECT_EQ(RoundTrip(attack), attack);  // the text itself is unchanged for the page, only inert in transit
}

TEST(JsonText, ValidUtf8IsKeptAndLineSeparatorsEscaped) {
  const std::string text = "F\xc3\xbc\xc3\x9f \xe2\x86\x92 \xf0\x9f\xa4\x96";  // "Füß → 🤖"
  EXPECT_EQ(JsonString(text), "\"" + text + "\"");
  EXPECT_EQ(RoundTrip(text), text);
  EXPECT_EQ(JsonString("a\xe2\x80\xa8"
                       "b\xe2\x80\xa9"),
            R"("a\u2028b\u2029")");
}

TEST(JsonText, InvalidUtf8BecomesReplacementCharacters) {
  // RFC 3629: a stray continuation byte, a truncated sequence, an overlong '/', a surrogate, beyond U+10FFFF, 0xFF.
  EXPECT_EQ(JsonString("a\x80z"), R"("a\ufffdz")");
  EXPECT_EQ(JsonString("a\xe2\x82"), R"("a\ufffd\ufffd")");
  EXPECT_EQ(JsonString("\xc0\xaf"), R"("\ufffd\ufffd")");
  EXPECT_EQ(JsonString("\xed\xa0\x80"), R"("\ufffd\ufffd\ufffd")");
  EXPECT_EQ(JsonString("\xf4\x90\x80\x80"), R"("\ufffd\ufffd\ufffd\ufffd")");
  EXPECT_EQ(JsonString("\xff"), R"("\ufffd")");
  // What remains is valid UTF-8 and parses.
  EXPECT_EQ(RoundTrip("ok\xff"), "ok\xef\xbf\xbd");
}

teleop::dds::StateTrace MakeTrace(const std::string& pair, const std::string& role) {
  teleop::dds::StateTrace t;
  t.pair = pair;
  t.role = role;
  t.cycle = 1234;
  t.time_s = 1.234;
  t.engagement = teleop::dds::Engagement::kCoupled;
  t.dof = 2;
  t.position_m = {0.001, -0.002, 9, 9, 9, 9};  // entries past dof must not appear
  t.peer_position_m = {0.0011, -0.0021};
  t.force_sensor_N = {0.5, std::numeric_limits<double>::quiet_NaN()};
  t.command_N = {-1.5, 2.5};
  t.fixture_penetration_m = 0.0003;
  t.tracking_error_m = 0.0001;
  t.rtt_ms = std::numeric_limits<double>::quiet_NaN();
  return t;
}

std::vector<std::string> Array(const pt::ptree& tree, const std::string& key) {
  std::vector<std::string> out;
  for (const auto& [k, v] : tree.get_child(key)) out.push_back(v.get_value<std::string>());
  return out;
}

TEST(DashboardMessages, StateCarriesDofEntriesAndNullForUnknown) {
  const std::string text = teleop::dds::EncodeState(MakeTrace("rig1", "master"), 12.5);
  const pt::ptree m = ParseJson(text);
  EXPECT_EQ(m.get<std::string>("type"), "state");
  EXPECT_DOUBLE_EQ(m.get<double>("t_s"), 12.5);
  EXPECT_EQ(m.get<std::string>("pair"), "rig1");
  EXPECT_EQ(m.get<std::string>("role"), "master");
  EXPECT_EQ(m.get<std::uint64_t>("cycle"), 1234U);
  EXPECT_EQ(m.get<std::string>("engagement"), "coupled");
  EXPECT_EQ(m.get<int>("dof"), 2);
  EXPECT_EQ(Array(m, "position_m"), (std::vector<std::string>{"0.001", "-0.002"}));
  EXPECT_EQ(Array(m, "force_sensor_N"), (std::vector<std::string>{"0.5", "null"}));
  EXPECT_EQ(Array(m, "command_N"), (std::vector<std::string>{"-1.5", "2.5"}));
  EXPECT_DOUBLE_EQ(m.get<double>("fixture_penetration_m"), 0.0003);
  EXPECT_NE(text.find(R"("rtt_ms":null)"), std::string::npos) << text;
  EXPECT_EQ(m.count("clutch"), 0U) << "no clutch field in a State without one";
}

// The fixture stiffness in use and its run-time limit, and an arm's joints (docs/dds.md, "The dashboard"): a
// Cartesian device's State has no joints and a process that computes no limit sends null, which the page draws as
// no line (never 0: a limit of 0 N/m is a value, "no stiffness is stable there").
TEST(DashboardMessages, StateCarriesTheFixtureStiffnessItsLimitAndTheJoints) {
  auto t = MakeTrace("rig1", "slave");
  t.fixture_stiffness_N_per_m = 2000.0;
  {
    const std::string text = teleop::dds::EncodeState(t, 0);
    const pt::ptree m = ParseJson(text);
    EXPECT_DOUBLE_EQ(m.get<double>("fixture_stiffness_N_per_m"), 2000.0);
    EXPECT_NE(text.find(R"("fixture_limit_N_per_m":null)"), std::string::npos) << "no limit computed: " << text;
    EXPECT_EQ(m.get<int>("joints"), 0);
    EXPECT_TRUE(Array(m, "joint_position_rad").empty()) << text;
    EXPECT_TRUE(Array(m, "joint_torque_Nm").empty()) << text;
  }
  t.fixture_stiffness_N_per_m = 1402.5;  // lowered to 0.1 x the limit (docs/arms.md, "At run time")
  t.fixture_limit_N_per_m = 14025.0;
  t.joints = 7;
  for (std::size_t j = 0; j < t.joint_position_rad.size(); ++j) {
    t.joint_position_rad[j] =
        j < 7 ? 0.25 * static_cast<double>(j + 1) : 99.0;  // entries past `joints` must not appear
    t.joint_torque_Nm[j] = j < 7 ? -1.5 * static_cast<double>(j + 1) : 99.0;
  }
  t.joint_torque_Nm[3] = std::numeric_limits<double>::quiet_NaN();
  const std::string text = teleop::dds::EncodeState(t, 0);
  const pt::ptree m = ParseJson(text);
  EXPECT_DOUBLE_EQ(m.get<double>("fixture_stiffness_N_per_m"), 1402.5);
  EXPECT_DOUBLE_EQ(m.get<double>("fixture_limit_N_per_m"), 14025.0);
  EXPECT_EQ(m.get<int>("joints"), 7);
  EXPECT_EQ(Array(m, "joint_position_rad"),
            (std::vector<std::string>{"0.25", "0.5", "0.75", "1", "1.25", "1.5", "1.75"}));
  EXPECT_EQ(Array(m, "joint_torque_Nm"),
            (std::vector<std::string>{"-1.5", "-3", "-4.5", "null", "-7.5", "-9", "-10.5"}));
  t.fixture_limit_N_per_m = 0.0;
  EXPECT_DOUBLE_EQ(ParseJson(teleop::dds::EncodeState(t, 0)).get<double>("fixture_limit_N_per_m"), 0.0)
      << "a limit of 0 is a value, not 'no limit'";
  t.joints = static_cast<std::uint8_t>(teleop::kMaxDof);
  EXPECT_EQ(Array(ParseJson(teleop::dds::EncodeState(t, 0)), "joint_position_rad").size(),
            static_cast<std::size_t>(teleop::kMaxDof));
}

TEST(DashboardMessages, ClutchAppearsOnlyWhenTheSampleHasOne) {
  auto t = MakeTrace("rig1", "slave");
  t.clutched = true;
  EXPECT_EQ(ParseJson(teleop::dds::EncodeState(t, 0)).get<std::string>("clutch"), "clutched");
  t.clutched = false;
  EXPECT_EQ(ParseJson(teleop::dds::EncodeState(t, 0)).get<std::string>("clutch"), "released");
}

TEST(DashboardMessages, ProcessesEscapeEveryTextFromDds) {
  teleop::dds::ProcessView v;
  v.pair = "rig1";
  v.role = "slave";
  v.have_state = true;
  v.status = teleop::dds::ProcessView::Status::kStale;
  v.engagement = teleop::dds::Engagement::kPeerLost;
  v.age_s = 1.5;
  v.rtt_ms = std::numeric_limits<double>::quiet_NaN();
  v.last_event = "<b>x</b>\xff";
  v.stop_reason = "\"quoted\"\n";
  v.clutch = 4;  // the command channel
  teleop::dds::ProcessView waiting;
  waiting.pair = "rig2";
  waiting.role = "master";
  waiting.age_s = std::numeric_limits<double>::quiet_NaN();
  const std::string text = teleop::dds::EncodeProcesses({v, waiting}, 3.0);
  EXPECT_EQ(text.find('<'), std::string::npos) << text;
  const pt::ptree m = ParseJson(text);
  EXPECT_EQ(m.get<std::string>("type"), "processes");
  const auto& list = m.get_child("processes");
  ASSERT_EQ(list.size(), 2U);
  const pt::ptree& a = list.begin()->second;
  EXPECT_EQ(a.get<std::string>("status"), "stale");
  EXPECT_EQ(a.get<std::string>("engagement"), "peer_lost");
  EXPECT_EQ(a.get<std::string>("clutch"), "command");
  EXPECT_DOUBLE_EQ(a.get<double>("age_s"), 1.5);
  EXPECT_EQ(a.get<std::string>("rtt_ms"), "null");
  EXPECT_EQ(a.get<std::string>("last_event"), "<b>x</b>\xef\xbf\xbd");
  EXPECT_EQ(a.get<std::string>("stop_reason"), "\"quoted\"\n");
  const pt::ptree& b = std::next(list.begin())->second;
  EXPECT_EQ(b.get<std::string>("status"), "discovered");
  EXPECT_EQ(b.get<std::string>("engagement"), "null") << "no engagement before the first State";
  EXPECT_EQ(b.get<std::string>("clutch"), "null") << "no clutch before the first State";
  EXPECT_EQ(b.get<std::string>("age_s"), "null");
}

TEST(DashboardMessages, EventAndHello) {
  const pt::ptree e = ParseJson(teleop::dds::EncodeEvent("rig1", "master", "peer_lost", 77, 2.0, 4.5));
  EXPECT_EQ(e.get<std::string>("type"), "event");
  EXPECT_EQ(e.get<std::string>("kind"), "peer_lost");
  EXPECT_EQ(e.get<std::uint64_t>("cycle"), 77U);
  EXPECT_DOUBLE_EQ(e.get<double>("value"), 2.0);
  const pt::ptree h = ParseJson(teleop::dds::EncodeHello(0.5));
  EXPECT_EQ(h.get<std::string>("type"), "hello");
  EXPECT_EQ(h.get<int>("version"), teleop::dds::kDashboardProtocolVersion);
}

TEST(DashboardMessages, PageRequests) {
  using teleop::dds::DashboardRequest;
  using teleop::dds::ParseDashboardRequest;
  const auto rig1 = ParseDashboardRequest("subscribe rig1");
  ASSERT_TRUE(rig1);
  EXPECT_EQ(rig1->kind, DashboardRequest::Kind::kSubscribe);
  EXPECT_EQ(rig1->pair, "rig1");
  const auto none = ParseDashboardRequest("subscribe");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->pair, "");
  const auto table = ParseDashboardRequest("table 150");
  ASSERT_TRUE(table);
  EXPECT_EQ(table->kind, DashboardRequest::Kind::kTable);
  EXPECT_EQ(table->offset, 150U);
  const auto command = ParseDashboardRequest(
      "command 0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef slave gain kp_N_per_m 300 0.5");
  ASSERT_TRUE(command);
  EXPECT_EQ(command->kind, DashboardRequest::Kind::kCommand);
  EXPECT_EQ(command->role, "slave");
  EXPECT_EQ(command->line, "gain kp_N_per_m 300 0.5");
  for (const char* bad : {"",
                          "subscribe ",
                          "subscribe rig 1",
                          "subscribe ../x",
                          "subscribex",
                          "subscribe 1rig",
                          "subscribe a__b",
                          "unsubscribe rig1",
                          "subscribe rig1\n",
                          "table",
                          "table ",
                          "table -1",
                          "table 1e3",
                          "table 1234567890",
                          "table 5 ",
                          "command",
                          "command abc master clutch on",
                          "command 0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef master shutdown",
                          "command 0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef peer clutch on",
                          "command 0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef master clutch;on"})
    EXPECT_FALSE(ParseDashboardRequest(bad)) << "'" << bad << "'";
  EXPECT_FALSE(ParseDashboardRequest("subscribe " + std::string(65, 'a'))) << "longer than a pair name may be";
}

// One DOF limit (teleop::kMaxDof): a State carries the first kStateAxes axes (the IDL's arrays), which is no limit of
// its own; a 12-DOF trace shows its first kStateAxes.
TEST(DashboardMessages, StateAxesAreTheIdlArraysNotASecondDofLimit) {
  static_assert(std::tuple_size_v<teleop::dds::StateTrace::Axes> == teleop::dds::kStateAxes);
  EXPECT_LE(teleop::dds::kStateAxes, static_cast<std::size_t>(teleop::kMaxDof));
  auto t = MakeTrace("rig1", "master");
  t.dof = static_cast<std::uint8_t>(teleop::kMaxDof);
  EXPECT_EQ(Array(ParseJson(teleop::dds::EncodeState(t, 0)), "position_m").size(), teleop::dds::kStateAxes);
}

// 2400 pairs once made a 698 KB table message ten times a second per page: the table goes out a page of rows at a
// time (plus the page's own pair, wherever it sits), so a message's size does not grow with the domain.
TEST(DashboardMessages, TheTableIsPagedAndCarriesThePagesOwnPair) {
  std::vector<teleop::dds::ProcessView> views;
  for (int i = 0; i < 2400; ++i) {
    teleop::dds::ProcessView v;
    v.pair = fmt::format("p{:04d}", i / 2);
    v.role = i % 2 == 0 ? "master" : "slave";
    v.age_s = 0.1;
    views.push_back(v);
  }
  const std::string text = teleop::dds::EncodeProcesses(views, 1.0, 50, 50, "p1100");
  EXPECT_LT(text.size(), 40'000U) << "52 rows, not 2400";
  const pt::ptree m = ParseJson(text);
  EXPECT_EQ(m.get<std::size_t>("total"), 2400U);
  EXPECT_EQ(m.get<std::size_t>("offset"), 50U);
  const auto& rows = m.get_child("processes");
  ASSERT_EQ(rows.size(), 50U);
  EXPECT_EQ(rows.begin()->second.get<std::string>("pair"), "p0025");
  const auto& chosen = m.get_child("chosen");
  ASSERT_EQ(chosen.size(), 2U);
  EXPECT_EQ(chosen.begin()->second.get<std::string>("pair"), "p1100");
  const pt::ptree past = ParseJson(teleop::dds::EncodeProcesses(views, 1.0, 5000, 50, ""));
  EXPECT_EQ(past.get_child("processes").size(), 0U);
  EXPECT_EQ(past.get_child("chosen").size(), 0U);
}

// DNS rebinding: a page of another site whose name was rebound to 127.0.0.1 sends its own name in Host.
TEST(DashboardHost, OnlyTheBoundAddressLocalhostAndAllowedNames) {
  using teleop::dds::HostHeaderAllowed;
  const std::vector<std::string> none;
  for (const char* ok : {"127.0.0.1:8080", "localhost:8080", "LocalHost:8080", "[::1]:8080", "127.0.0.2:8080"})
    EXPECT_TRUE(HostHeaderAllowed(ok, "127.0.0.1", 8080, none)) << ok;
  for (const char* bad :
       {"evil.example:8080", "evil.example", "127.0.0.1:8081", "127.0.0.1", "127.0.0.1:", "", "10.0.0.5:8080",
        "localhost.evil.example:8080", "[::1", "[::1]x", "::1:8080", "127.0.0.1:8080x", "127.0.0.1:99999999"})
    EXPECT_FALSE(HostHeaderAllowed(bad, "127.0.0.1", 8080, none)) << "'" << bad << "'";
  EXPECT_TRUE(HostHeaderAllowed("127.0.0.1", "127.0.0.1", 80, none)) << "no port means 80";
  EXPECT_TRUE(HostHeaderAllowed("10.0.0.5:8080", "10.0.0.5", 8080, none));
  EXPECT_TRUE(HostHeaderAllowed("10.0.0.5:8080", "0.0.0.0", 8080, none)) << "every interface: any address";
  EXPECT_FALSE(HostHeaderAllowed("labpc:8080", "0.0.0.0", 8080, none)) << "a name only when allowed";
  EXPECT_TRUE(HostHeaderAllowed("labpc:8080", "0.0.0.0", 8080, {"labpc"}));
}

TEST(DashboardEndpoint, ParsesPortAddressAndIpv6) {
  using teleop::dds::ParseHttpEndpoint;
  const auto a = ParseHttpEndpoint("8080");
  EXPECT_EQ(a.address, "127.0.0.1") << "localhost unless an address is given";
  EXPECT_EQ(a.port, 8080);
  const auto b = ParseHttpEndpoint("0.0.0.0:80");
  EXPECT_EQ(b.address, "0.0.0.0");
  EXPECT_EQ(b.port, 80);
  const auto c = ParseHttpEndpoint("[::1]:8081");
  EXPECT_EQ(c.address, "::1");
  EXPECT_EQ(c.port, 8081);
  for (const char* bad : {"", "localhost:8080", "127.0.0.1:0", "127.0.0.1:65536", "127.0.0.1:", ":8080", "::1:8080",
                          "[::1]8080", "127.0.0.1:80x", "300.1.1.1:80"})
    EXPECT_THROW(ParseHttpEndpoint(bad), teleop::Error) << "'" << bad << "'";
}

// ---- the server over real sockets ----------------------------------------------------------------------------

/// A dygraphs directory of the test's own (so the test does not depend on libjs-dygraphs being installed).
std::string FakeDygraphs() {
  // In the test's working directory (ctest: build/tests/dds), replaced on every run.
  const auto dir = std::filesystem::current_path() / "dashboard_test_dygraphs";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "dygraph.min.js") << "/* fake */ var Dygraph = function () {};";
  std::ofstream(dir / "dygraph.min.css") << ".dygraph-legend {}";
  return dir.string();
}

DashboardServer::Config TestConfig() {
  DashboardServer::Config c;
  c.endpoint = {"127.0.0.1", 0};  // the kernel's choice
  c.dygraphs_dir = FakeDygraphs();
  return c;
}

http::response<http::string_body> Get(std::uint16_t port, const std::string& target, http::verb verb = http::verb::get,
                                      const std::string& host = "", const std::string& from = "127.0.0.1") {
  net::io_context io;
  tcp::socket socket(io);
  socket.open(tcp::v4());
  socket.bind({net::ip::make_address(from), 0});
  socket.connect({net::ip::make_address("127.0.0.1"), port});
  http::request<http::empty_body> request(verb, target, 11);
  request.set(http::field::host, host.empty() ? "127.0.0.1:" + std::to_string(port) : host);
  request.keep_alive(false);
  http::write(socket, request);
  beast::flat_buffer buffer;
  http::response<http::string_body> response;
  http::read(socket, buffer, response);
  return response;
}

/// A WebSocket client with a deadline on every read (a test must not hang on a server that stays silent).
class Client {
 public:
  Client(std::uint16_t port, const std::string& origin = "") : ws_(io_) {
    beast::get_lowest_layer(ws_).connect(tcp::endpoint{net::ip::make_address("127.0.0.1"), port});
    if (!origin.empty())
      ws_.set_option(websocket::stream_base::decorator(
          [origin](websocket::request_type& r) { r.set(http::field::origin, origin); }));
    ws_.handshake("127.0.0.1:" + std::to_string(port), "/ws");
  }
  void Send(const std::string& text) { ws_.write(net::buffer(text)); }
  /// The next message, or nullopt after `timeout` (or when the connection ended).
  std::optional<std::string> Read(std::chrono::milliseconds timeout = std::chrono::milliseconds(3000)) {
    beast::flat_buffer buffer;
    std::optional<beast::error_code> result;
    ws_.async_read(buffer, [&](beast::error_code ec, std::size_t) { result = ec; });
    io_.restart();
    io_.run_for(timeout);
    if (!result) {
      beast::get_lowest_layer(ws_).cancel();
      io_.restart();
      io_.run();
      return std::nullopt;
    }
    if (*result) return std::nullopt;
    return beast::buffers_to_string(buffer.data());
  }
  /// The next message of `type` (others skipped), or nullopt.
  std::optional<pt::ptree> ReadType(const std::string& type) {
    for (int i = 0; i < 100; ++i) {
      const auto text = Read();
      if (!text) return std::nullopt;
      pt::ptree m = ParseJson(*text);
      if (m.get<std::string>("type") == type) return m;
    }
    return std::nullopt;
  }
  tcp::socket& socket() { return beast::get_lowest_layer(ws_).socket(); }

 private:
  net::io_context io_;
  websocket::stream<beast::tcp_stream> ws_;
};

TEST(DashboardServer, ServesThePageItsAssetsAndDygraphsAndNothingElse) {
  DashboardServer server(TestConfig());
  ASSERT_NE(server.port(), 0);
  EXPECT_TRUE(server.have_dygraphs());
  const auto page = Get(server.port(), "/");
  EXPECT_EQ(page.result(), http::status::ok);
  EXPECT_NE(page[http::field::content_type].find("text/html"), beast::string_view::npos);
  EXPECT_NE(page.body().find("/dygraph.min.js"), std::string::npos);
  EXPECT_NE(page.body().find("/dashboard.js"), std::string::npos);
  EXPECT_FALSE(page["Content-Security-Policy"].empty());
  EXPECT_EQ(Get(server.port(), "/?pair=rig1").result(), http::status::ok);
  const auto script = Get(server.port(), "/dashboard.js");
  EXPECT_EQ(script.result(), http::status::ok);
  EXPECT_NE(script.body().find("textContent"), std::string::npos);
  EXPECT_EQ(script.body().find("innerHTML"), std::string::npos) << "the page never parses text as HTML";
  EXPECT_EQ(Get(server.port(), "/dashboard.css").result(), http::status::ok);
  const auto dygraphs = Get(server.port(), "/dygraph.min.js");
  EXPECT_EQ(dygraphs.result(), http::status::ok);
  EXPECT_EQ(dygraphs.body(), "/* fake */ var Dygraph = function () {};");
  for (const char* target : {"/etc/passwd", "/../dygraph.min.js", "/dygraph.js", "/ws/../index.html"})
    EXPECT_EQ(Get(server.port(), target).result(), http::status::not_found) << target;
  EXPECT_EQ(Get(server.port(), "/", http::verb::post).result(), http::status::method_not_allowed);
}

TEST(DashboardServer, WithoutDygraphsThePageIsStillServed) {
  auto config = TestConfig();
  config.dygraphs_dir = "/nonexistent/dygraphs";
  DashboardServer server(config);
  EXPECT_FALSE(server.have_dygraphs());
  EXPECT_EQ(Get(server.port(), "/").result(), http::status::ok);
  const auto js = Get(server.port(), "/dygraph.min.js");
  EXPECT_EQ(js.result(), http::status::not_found);
  EXPECT_NE(js.body().find("libjs-dygraphs"), std::string::npos);
}

TEST(DashboardServer, ABusyPortIsAClearError) {
  DashboardServer first(TestConfig());
  auto config = TestConfig();
  config.endpoint.port = first.port();
  try {
    DashboardServer second(config);
    FAIL() << "a second server on the same port";
  } catch (const teleop::Error& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(first.port())), std::string::npos) << e.what();
  }
}

TEST(DashboardServer, StreamsTheTableToAllAndStatesOnlyOfTheSubscribedPair) {
  DashboardServer server(TestConfig());
  Client client(server.port());
  ASSERT_TRUE(client.ReadType("hello"));
  teleop::dds::ProcessView v;
  v.pair = "rig1";
  v.role = "master";
  server.PublishProcesses({v}, 1.0);
  const auto table = client.ReadType("processes");
  ASSERT_TRUE(table);
  EXPECT_EQ(table->get_child("processes").begin()->second.get<std::string>("pair"), "rig1");

  client.Send("subscribe rig1");
  // The subscription is read on the server thread: publish until the first rig1 state arrives.
  std::optional<pt::ptree> state;
  for (int i = 0; i < 20 && !state; ++i) {
    server.PublishState(MakeTrace("rig2", "master"), 2.0);
    server.PublishState(MakeTrace("rig1", "slave"), 2.0);
    const auto text = client.Read(std::chrono::milliseconds(200));
    if (text && ParseJson(*text).get<std::string>("type") == "state") state = ParseJson(*text);
  }
  ASSERT_TRUE(state);
  EXPECT_EQ(state->get<std::string>("pair"), "rig1");
  // From here on: rig2's states never arrive, rig1's and its events do.
  for (int i = 0; i < 5; ++i) server.PublishState(MakeTrace("rig2", "master"), 3.0);
  server.PublishEvent("rig2", "master", "peer_lost", 1, 0, 3.0);
  server.PublishEvent("rig1", "slave", "peer_lost", 2, 0, 3.0);
  const auto event = client.ReadType("event");
  ASSERT_TRUE(event);
  EXPECT_EQ(event->get<std::string>("pair"), "rig1");
  EXPECT_EQ(event->get<std::uint64_t>("cycle"), 2U);

  client.Send("subscribe </script>");  // not a pair name: counted, the subscription stays
  server.PublishState(MakeTrace("rig1", "slave"), 4.0);
  const auto again = client.ReadType("state");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->get<std::string>("pair"), "rig1");
  // The malformed request is counted on the server thread, in no fixed order with the tick that sent the state.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (server.stats().requests_malformed == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(server.stats().requests_malformed, 1U);
  EXPECT_EQ(server.stats().websocket_clients, 1U);
}

TEST(DashboardServer, AWebSocketFromAnotherSiteIsRefused) {
  DashboardServer server(TestConfig());
  EXPECT_THROW(Client(server.port(), "http://evil.example"), boost::system::system_error);
  EXPECT_EQ(server.stats().websocket_refused, 1U);
  // The scheme counts too: the page is served over http only.
  EXPECT_THROW(Client(server.port(), "https://127.0.0.1:" + std::to_string(server.port())),
               boost::system::system_error);
  EXPECT_EQ(server.stats().websocket_refused, 2U);
  Client own(server.port(), "http://127.0.0.1:" + std::to_string(server.port()));
  EXPECT_TRUE(own.ReadType("hello")) << "the server's own page may";
}

TEST(DashboardServer, ASlowClientIsDroppedAndPublishingGoesOn) {
  auto config = TestConfig();
  config.client_queue_bytes = 64 * 1024;
  DashboardServer server(config);
  Client slow(server.port());
  slow.socket().set_option(net::socket_base::receive_buffer_size(4096));
  ASSERT_TRUE(slow.ReadType("hello"));
  slow.Send("subscribe rig1");
  // The slow client never reads again: its TCP window closes, the kernel's buffers fill, then its queue at the
  // server passes 64 KiB and the server drops it. Publishing never waits for it (the calls only append).
  const auto trace = MakeTrace("rig1", "master");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  std::uint64_t published = 0;
  while (server.stats().clients_dropped_slow == 0 && std::chrono::steady_clock::now() < deadline) {
    for (int i = 0; i < 200; ++i, ++published) server.PublishState(trace, 0.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(server.stats().clients_dropped_slow, 1U) << "after " << published << " states";
  EXPECT_EQ(server.stats().websocket_clients, 0U);
  // The server still serves: a new client gets its hello and the states.
  Client fresh(server.port());
  EXPECT_TRUE(fresh.ReadType("hello"));
  fresh.Send("subscribe rig1");
  std::optional<pt::ptree> state;
  for (int i = 0; i < 20 && !state; ++i) {
    server.PublishState(trace, 1.0);
    const auto text = fresh.Read(std::chrono::milliseconds(200));
    if (text && ParseJson(*text).get<std::string>("type") == "state") state = ParseJson(*text);
  }
  EXPECT_TRUE(state);
}

TEST(DashboardServer, AFullQueueDropsAndCountsSamples) {
  auto config = TestConfig();
  config.max_pending = 10;
  DashboardServer server(config);
  const auto trace = MakeTrace("rig1", "master");
  for (int i = 0; i < 1000; ++i) server.PublishState(trace, 0.0);
  // The server thread drains every 50 ms; within this loop (well under a millisecond) at most a few drains.
  const auto dropped = server.stats().samples_dropped;
  EXPECT_GT(dropped, 900U);
  EXPECT_LE(dropped, 990U);
}

TEST(DashboardServer, AForeignHostGets403EvenForThePage) {
  DashboardServer server(TestConfig());
  const std::string port = std::to_string(server.port());
  EXPECT_EQ(Get(server.port(), "/", http::verb::get, "localhost:" + port).result(), http::status::ok);
  const auto rebound = Get(server.port(), "/", http::verb::get, "evil.example:" + port);
  EXPECT_EQ(rebound.result(), http::status::forbidden);
  EXPECT_EQ(rebound.body().find("<html"), std::string::npos);
  EXPECT_EQ(Get(server.port(), "/dashboard.js", http::verb::get, "evil.example:" + port).result(),
            http::status::forbidden);
  EXPECT_EQ(server.stats().requests_foreign_host, 2U);
}

// 32 connections that answered pings once held every new page off for good: one address gets at most
// max_connections_per_peer, and a page that says nothing for page_idle_timeout_s is dropped.
TEST(DashboardServer, OnePeerCannotTakeEveryConnection) {
  auto config = TestConfig();
  config.max_connections_per_peer = 3;
  DashboardServer server(config);
  net::io_context io;
  std::vector<tcp::socket> held;
  for (int i = 0; i < 3; ++i) {
    held.emplace_back(io);
    held.back().connect({net::ip::make_address("127.0.0.1"), server.port()});
  }
  // Accepted on the server thread: wait until it holds all three.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (server.stats().connections_accepted < 3 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_THROW(Get(server.port(), "/"), boost::system::system_error) << "a fourth from the same address";
  EXPECT_EQ(server.stats().connections_refused, 1U);
  EXPECT_EQ(Get(server.port(), "/", http::verb::get, "", "127.0.0.2").result(), http::status::ok)
      << "another address is still served";
}

TEST(DashboardServer, APageThatSaysNothingIsDropped) {
  auto config = TestConfig();
  config.page_idle_timeout_s = 0.3;
  DashboardServer server(config);
  Client silent(server.port());
  Client talking(server.port());
  ASSERT_TRUE(silent.ReadType("hello"));
  ASSERT_TRUE(talking.ReadType("hello"));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (server.stats().clients_dropped_idle == 0 && std::chrono::steady_clock::now() < deadline) {
    talking.Send("subscribe rig1");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(server.stats().clients_dropped_idle, 1U);
  EXPECT_EQ(server.stats().websocket_clients, 1U) << "the page that speaks stays";
}

// A page opened mid-run showed empty plots: on subscribing it gets the pair's last history_s seconds at once (states
// and events, oldest first), bounded in time and bytes, and nothing of other pairs.
TEST(DashboardServer, ANewPageGetsThePairsHistoryAtOnce) {
  auto config = TestConfig();
  config.history_s = 10.0;
  DashboardServer server(config);
  for (int i = 0; i <= 200; ++i) {
    const double t_s = 0.1 * i;
    server.PublishState(MakeTrace("rig1", i % 2 == 0 ? "master" : "slave"), t_s);
    server.PublishState(MakeTrace("rig2", "master"), t_s);
  }
  server.PublishEvent("rig1", "master", "overrun", 7, 0, 20.0);
  // Queued for the server thread, which drains every 50 ms: wait until the event is in the history.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  Client client(server.port());
  const auto hello = client.ReadType("hello");
  ASSERT_TRUE(hello);
  EXPECT_DOUBLE_EQ(hello->get<double>("history_s"), 10.0);
  client.Send("subscribe rig1");
  std::vector<double> times;
  bool event = false;
  while (const auto text = client.Read(std::chrono::milliseconds(500))) {
    const pt::ptree m = ParseJson(*text);
    const auto type = m.get<std::string>("type");
    if (type == "state") {
      EXPECT_EQ(m.get<std::string>("pair"), "rig1");
      times.push_back(m.get<double>("t_s"));
    }
    if (type == "event") event = true;
  }
  ASSERT_FALSE(times.empty()) << "no history sent";
  EXPECT_TRUE(event) << "the event is in the history";
  EXPECT_NEAR(times.front(), 10.0, 0.05) << "the last 10 s, not more";
  EXPECT_NEAR(times.back(), 20.0, 1e-9);
  EXPECT_EQ(times.size(), 101U);
  EXPECT_TRUE(std::is_sorted(times.begin(), times.end())) << "oldest first";
}

TEST(DashboardServer, TheHistoryIsBoundedInBytes) {
  auto config = TestConfig();
  config.history_s = 1e6;
  config.history_bytes = 16 * 1024;
  DashboardServer server(config);
  for (int i = 0; i < 2000; ++i) server.PublishState(MakeTrace("rig1", "master"), 0.01 * i);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  Client client(server.port());
  ASSERT_TRUE(client.ReadType("hello"));
  client.Send("subscribe rig1");
  std::size_t bytes = 0;
  std::size_t states = 0;
  while (const auto text = client.Read(std::chrono::milliseconds(500))) {
    if (ParseJson(*text).get<std::string>("type") != "state") continue;
    bytes += text->size();
    ++states;
  }
  EXPECT_GT(states, 10U);
  EXPECT_LE(bytes, 16U * 1024U);
  EXPECT_LT(states, 2000U);
}

// Commands from the page (issue 30 item 3): only with a token configured (teleop-supervise --allow-commands), only
// with that token, only the coupling commands, at a bounded rate; each goes to the process's command channel (here
// a recording handler) and comes back, with who sent it, to every page of the pair.
TEST(DashboardServer, CommandsNeedTheFlagAndTheTokenAndAreEvents) {
  const std::string token(64, 'a');
  const std::string command = "command " + token + " master clutch on";
  {
    DashboardServer server(TestConfig());  // no --allow-commands: read-only
    Client page(server.port());
    const auto hello = page.ReadType("hello");
    ASSERT_TRUE(hello);
    EXPECT_EQ(hello->get<std::string>("commands"), "false");
    page.Send("subscribe rig1");
    page.Send(command);
    const auto reply = page.ReadType("command");
    ASSERT_TRUE(reply);
    EXPECT_NE(reply->get<std::string>("reply").find("commands are off"), std::string::npos);
    EXPECT_EQ(server.stats().commands_forwarded, 0U);
  }
  std::mutex mutex;
  std::vector<std::string> forwarded;
  auto config = TestConfig();
  config.command_token = token;
  config.commands_per_s = 2.0;
  config.command_handler = [&](const std::string& pair, const std::string& role, const std::string& line) {
    const std::lock_guard<std::mutex> lock(mutex);
    forwarded.push_back(pair + "/" + role + ": " + line);
    return std::string("ok: ") + line;
  };
  DashboardServer server(config);
  Client page(server.port());
  Client watcher(server.port());
  const auto hello = page.ReadType("hello");
  ASSERT_TRUE(hello);
  EXPECT_EQ(hello->get<std::string>("commands"), "true");
  ASSERT_TRUE(watcher.ReadType("hello"));
  watcher.Send("subscribe rig1");
  page.Send("subscribe rig1");
  page.Send("command " + std::string(64, 'b') + " master clutch on");
  const auto wrong = page.ReadType("command");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->get<std::string>("reply"), "error: wrong token");
  page.Send("command " + token + " master shutdown");  // not a command a page may send: malformed
  page.Send(command);
  const auto done = watcher.ReadType("command");
  ASSERT_TRUE(done) << "the other page of the pair sees the command";
  EXPECT_EQ(done->get<std::string>("text"), "clutch on");
  EXPECT_EQ(done->get<std::string>("reply"), "ok: clutch on");
  EXPECT_EQ(done->get<std::string>("from").rfind("127.0.0.1:", 0), 0U) << "who sent it";
  page.Send(command);
  page.Send(command);  // the third within a second of two allowed per second
  std::optional<pt::ptree> refused;
  for (int i = 0; i < 5 && !refused; ++i) {
    const auto m = page.ReadType("command");
    if (m && m->get<std::string>("reply").rfind("error: more than", 0) == 0) refused = m;
  }
  EXPECT_TRUE(refused) << "over the rate";
  const std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(forwarded.size(), 2U);
  EXPECT_EQ(forwarded[0], "rig1/master: clutch on");
  EXPECT_EQ(server.stats().commands_refused, 2U);
  EXPECT_EQ(server.stats().requests_malformed, 1U);
}

}  // namespace
