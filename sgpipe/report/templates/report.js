// Image-comparison sliders: the method's image is clipped to the left of the slider position,
// the reference shows through on the right. No network, no libraries.
(function () {
  "use strict";
  var boxes = document.querySelectorAll(".compare");
  Array.prototype.forEach.call(boxes, function (box) {
    var over = box.querySelector("img.over");
    var line = box.querySelector(".divider");
    var input = box.querySelector("input[type=range]");
    var readout = document.getElementById(box.getAttribute("data-readout"));
    function update() {
      var v = Number(input.value);
      over.style.clipPath = "inset(0 " + (100 - v) + "% 0 0)";
      line.style.left = v + "%";
      if (readout) {
        readout.textContent = v + "% " + box.getAttribute("data-left") + " | " +
          (100 - v) + "% " + box.getAttribute("data-right");
      }
    }
    input.addEventListener("input", update);
    update();
  });
})();
