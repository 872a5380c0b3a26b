// ros2d needs EventEmitter2 as a global. eventemitter2's own wrapper finds the global object
// with `new Function(...)`, which the console's Content-Security-Policy (no eval) forbids; so
// offer it an AMD `define` for that one call and keep what it hands over.
(function () {
  'use strict';
  function define(factory) {
    window.EventEmitter2 = factory();
    delete window.define;
  }
  define.amd = true;
  window.define = define;
})();
