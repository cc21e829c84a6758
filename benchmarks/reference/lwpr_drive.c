/* Runs the reference LWPR library (Klanke, Vijayakumar & Schaal, v1.2.x; not part of dogged) over
 * a stream, for benchmarks/lib/lwpr_reference.py. Training rows (inputs then outputs, float64, in
 * update order) and test inputs come from files; the test predictions after every `every` updates
 * go to `out`.
 * argv: nIn nOut init_D w_gen diag_only meta init_alpha train test out [every]
 * init_D or init_alpha <= 0 keeps the library's default. */
#include <lwpr.h>
#include <stdio.h>
#include <stdlib.h>
static double *load(const char *p, long *count) {
  FILE *f = fopen(p, "rb");
  if (f == NULL) { perror(p); exit(2); }
  fseek(f, 0, SEEK_END); long b = ftell(f); fseek(f, 0, SEEK_SET);
  double *d = malloc(b); if (fread(d, 1, b, f) != (size_t)b) exit(2); fclose(f); *count = b / 8; return d;
}
int main(int argc, char **argv) {
  if (argc < 11) { fprintf(stderr, "usage: see the comment at the top of lwpr_drive.c\n"); return 2; }
  int nIn = atoi(argv[1]), nOut = atoi(argv[2]);
  if (nIn < 1 || nOut < 1 || nOut > 64) { fprintf(stderr, "nIn >= 1 and 1 <= nOut <= 64\n"); return 2; }
  LWPR_Model model; lwpr_init_model(&model, nIn, nOut, "ref");
  if (atof(argv[3]) > 0) lwpr_set_init_D_spherical(&model, atof(argv[3]));
  model.w_gen = atof(argv[4]); model.diag_only = atoi(argv[5]); model.meta = atoi(argv[6]);
  if (atof(argv[7]) > 0) lwpr_set_init_alpha(&model, atof(argv[7]));
  long nt, ns; double *tr = load(argv[8], &nt), *te = load(argv[9], &ns);
  long rows = nt / (nIn + nOut), trows = ns / nIn;
  long every = argc > 11 ? atol(argv[11]) : rows;  /* predictions of the test inputs after every `every` updates */
  if (every < 1) { fprintf(stderr, "every must be >= 1\n"); return 2; }
  double yp[64], w[64];  /* w: the strongest activation per output */
  FILE *o = fopen(argv[10], "wb");
  if (o == NULL) { perror(argv[10]); exit(2); }
  for (long done = 0; done < rows;) {
    long stop = done + every < rows ? done + every : rows;
    for (long r = done; r < stop; r++) lwpr_update(&model, tr + r * (nIn + nOut), tr + r * (nIn + nOut) + nIn, yp, w);
    for (long r = 0; r < trows; r++) { lwpr_predict(&model, te + r * nIn, 0.001, yp, NULL, NULL); fwrite(yp, 8, nOut, o); }
    done = stop;
  }
  fclose(o);
  return 0;
}
