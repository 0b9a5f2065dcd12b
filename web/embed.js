// The embedding example's wiring: plain DOM events and properties of <kloub-viewer>.
// Runs before kloub-viewer.js defines the element, so ?backend=webgpu|webgl2 applies from the start.
const backend = new URLSearchParams(location.search).get('backend');
if (backend) document.querySelectorAll('kloub-viewer').forEach((v) => v.setAttribute('backend', backend));
for (const id of ['left', 'right']) {
  const viewer = document.getElementById(id);
  const log = document.getElementById(`${id}-log`);
  for (const type of ['load', 'error', 'play', 'pause', 'loop', 'finished']) {
    viewer.addEventListener(type, (e) => {
      log.textContent = `${type}${e.detail?.message ? `: ${e.detail.message}` : ''} · ${viewer.animationName} ${viewer.currentTime.toFixed(2)} s`;
    });
  }
}
const left = document.getElementById('left');
const toggle = document.getElementById('left-toggle');
toggle.addEventListener('click', () => (left.paused ? left.play() : left.pause()));
left.addEventListener('play', () => { toggle.textContent = 'Pause'; });
left.addEventListener('pause', () => { toggle.textContent = 'Play'; });
const right = document.getElementById('right');
document.getElementById('right-replay').addEventListener('click', () => {
  right.currentTime = 0;
  right.play();
});
