#pragma once

#include <string_view>

namespace teleop::dds {

/// The dashboard's page, script and style (common/src/dds/dashboard/), embedded at build time by
/// embed_dashboard.cmake into dashboard_assets.cpp, so teleop-supervise serves them from any directory.
std::string_view DashboardPageHtml() noexcept;
std::string_view DashboardPageScript() noexcept;
std::string_view DashboardPageStyle() noexcept;

}  // namespace teleop::dds
