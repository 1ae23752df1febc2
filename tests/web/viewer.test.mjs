// Browser tests of the viewer (web/) in Debian's headless Chromium, driven by playwright-core.
// Started by tests/web/run.sh, which runs the daemon and passes it in PCWEB_* variables (see
// viewer/session.mjs). The tests run in order on one page (a second and third page join for the
// views tests), in one process: they are one session, each topic leaving the page and the daemon
// as the next one expects, and the restart test hands its daemon to the last test. Each asserts
// what the user would see. The stream speaks version 2 (protocol/stream.md): every page owns a
// view of its own, and the world reaches it as events, never by polling.
//
// The topics, in the order they run (node:test runs tests in the order they are declared):
import './viewer/session.mjs'; // the browser, page A, the daemon; the helpers bound to them
import './viewer/stream.mjs'; // the page loads; frames arrive, are drawn and acknowledged
import './viewer/camera.mjs'; // orbit, the camera in the URL, wheel, pan, fly, pinch
import './viewer/panels.mjs'; // lights, GI mode and the probe view, the environment
import './viewer/layout.mjs'; // phone and desktop layouts, interactive resolution, quality, stats
import './viewer/views.mjs'; // a second page: own views, following, events, hiding
import './viewer/daemon.mjs'; // a rejected upload, a restart, resize, an upload, a token; the end
