// Loaded after require.js and before the ipywidgets bundle (embed-amd.js); see _config.yml (nb_ipywidgets_js).
(function () {
  // The bundle's webpack public path is the URL its AMD module name resolves to, by default the *page's* folder
  // (notebooks/@jupyter-widgets/html-manager/dist/): its icon fonts were fetched from there and missing. Map the name
  // to _static/widgets/, where tools/vendor_web_assets.py copies the bundle and its fonts.
  var here = document.currentScript.src.replace(/[^/]*$/, "");
  require.config({paths: {"@jupyter-widgets/html-manager/dist": here + "widgets"}});
  // The bundle takes its public path from the URL require.js gives its anonymous module, which depends on which
  // widget module is asked for first: now and then notebooks/@jupyter-widgets/, and a checkbox's icon font was
  // missing (s5, once in eight loads). It reads this override first, so the fonts come from one place.
  window.__jupyter_widgets_assets_path__ = here + "widgets/";

  // ipywidgets typesets widget labels with MathJax 2's MathJax.Hub.Queue; the book loads MathJax 3, which has no Hub.
  // A Hub that forwards to MathJax 3, installed before the widgets render (they render on the page's load event).
  window.addEventListener("load", function () {
    var mj = window.MathJax;
    if (mj && !mj.Hub && mj.typesetPromise) {
      mj.Hub = {
        Queue: function (job) {
          var element = job && job[2];
          var ready = (mj.startup && mj.startup.promise) || Promise.resolve();
          ready.then(function () { return mj.typesetPromise(element ? [element] : undefined); })
               .catch(function (err) { console.warn("MathJax could not typeset a widget label", err); });
        },
      };
    }
  });
})();
