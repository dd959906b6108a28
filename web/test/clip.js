// A raw RGBA clip for the test and benchmark pages: one file of w x h frames one after the
// other, as ffmpeg's `-f rawvideo -pix_fmt rgba` writes them.

/** Fetches the clip at `url`; `{ n, frame(i) }`, `frame(i)` an ImageData over frame i's bytes. */
export async function readClip(url, w, h) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`cannot fetch the clip: HTTP ${response.status}`);
  const bytes = await response.arrayBuffer();
  const size = w * h * 4;
  if (!(size > 0) || bytes.byteLength % size !== 0) {
    throw new Error(`the clip has ${bytes.byteLength} bytes, not a whole number of ${w}x${h} RGBA frames`);
  }
  return {
    n: bytes.byteLength / size,
    frame: (i) => new ImageData(new Uint8ClampedArray(bytes, i * size, size), w, h),
  };
}
