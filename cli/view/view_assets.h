// The files `vinci view` writes into its pages, embedded at build time (cli/view/view.cmake).
#pragma once

namespace vinci::cli::view_assets {

/// false if three.js was not found at build time (the strings below are then empty but the
/// template and viewer).
extern const bool kHaveThree;
extern const char* const kViewerHtml;       ///< cli/view/viewer.html, with @VINCI_...@ markers
extern const char* const kViewerJs;         ///< cli/view/viewer.js
extern const char* const kThreeJs;          ///< three.min.js (libjs-three)
extern const char* const kOrbitControlsJs;  ///< examples/js/controls/OrbitControls.js

}  // namespace vinci::cli::view_assets
