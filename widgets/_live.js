// The app shell's live channel (anywidget ESM): tells the kernel while a slider of its
// app is held. The kernel hears a dragged slider's values but not the mouse: without
// this, a pause in a drag looked like a release and started a render under the user's
// hand. A press on any slider of the app sets `held`; the release (anywhere in the
// page, or the window losing focus) clears it -- one message each.

export default {
  render({ model, el }) {
    el.style.display = "none";
    let app = null;
    let tries = 0;
    const set = (on) => {
      if (model.get("held") === on) return;
      model.set("held", on);
      model.save_changes();
    };
    const isSlider = (t) =>
      t instanceof Element && t.closest(".widget-slider, .noUi-target, .widget-hslider") !== null;
    const down = (e) => {
      if (isSlider(e.target)) set(true);
    };
    const up = () => set(false);
    const attach = () => {
      app = el.closest(".fluidnb-app");
      if (app) app.addEventListener("pointerdown", down, true);
      else if (tries++ < 400) setTimeout(attach, 50); // not in the page yet
    };
    attach();
    for (const type of ["pointerup", "pointercancel"]) window.addEventListener(type, up, true);
    window.addEventListener("blur", up);
    return () => {
      if (app) app.removeEventListener("pointerdown", down, true);
      for (const type of ["pointerup", "pointercancel"]) window.removeEventListener(type, up, true);
      window.removeEventListener("blur", up);
    };
  },
};
