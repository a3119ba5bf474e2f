/* Nothing waits for a render, also a command that was already waiting for the library when the
 * render began. In each round the main thread holds the library with a long command (vlSample
 * of a 256^3 dataset with the nearest filter, which makes its 64 MiB of node values first: some
 * tens of milliseconds) while a second thread calls vlAmbient, which has to wait for it; the
 * main thread then closes its scene at once, and the render's first field function call waits
 * up to five seconds for the second thread's call to return. That call must return while the
 * render goes on: VL_BADSCOPE (it found the scene rendering) or VL_NOERROR (it took the library
 * between the two commands), never after the render. A round whose call did not begin while
 * vlSample held the library shows nothing; rounds go on until three did (at most twenty).
 * Prints one line per check and exits non-zero if any fails. C89 (with POSIX threads); built
 * and run by capi/tests/c_examples.rs, and under valgrind by memcheck.rs. */
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include "checks.h"
#include <vlib.h>

#define ROUNDS 20
#define CONCLUSIVE 3

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t changed = PTHREAD_COND_INITIALIZER;
/* The round the second thread is to call in (0: none yet; -1: stop), the last round whose call
 * returned, and that call's error. */
static int go = 0, returned = 0;
static vlint code = VL_NOERROR;
/* Per round: whether the render's field function saw the call return in time, and whether the
 * call began while the main thread's vlSample held the library (else the round shows
 * nothing). */
static int in_time[ROUNDS + 1], began_inside[ROUNDS + 1];
static int current = 0, waited = 0, in_sample = 0;

static void pause_ms(long ms)
{
    struct timespec t;
    t.tv_sec = ms / 1000;
    t.tv_nsec = (ms % 1000) * 1000000L;
    nanosleep(&t, NULL);
}

static void *second(void *arg)
{
    int round = 0;
    (void)arg;
    for (;;) {
        vlint e;
        pthread_mutex_lock(&lock);
        while (go == round)
            pthread_cond_wait(&changed, &lock);
        round = go;
        pthread_mutex_unlock(&lock);
        if (round < 0)
            return NULL;
        /* By now the main thread is inside its long vlSample: this call waits for it. */
        pause_ms(1);
        pthread_mutex_lock(&lock);
        began_inside[round] = in_sample;
        pthread_mutex_unlock(&lock);
        vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
        e = vlError();
        pthread_mutex_lock(&lock);
        returned = round;
        code = e;
        pthread_cond_broadcast(&changed);
        pthread_mutex_unlock(&lock);
    }
}

/* The object's field: the first call of a round waits (five seconds at most) for the second
 * thread's call to return. */
static void field(vlvector p, void *misc)
{
    int i, first;
    (void)p;
    (void)misc;
    vlSet(VL_O, 0.5f);
    pthread_mutex_lock(&lock);
    first = waited != current;
    waited = current;
    pthread_mutex_unlock(&lock);
    if (!first)
        return;
    for (i = 0; i < 5000; i++) {
        int done;
        pthread_mutex_lock(&lock);
        done = returned == current;
        if (done)
            in_time[current] = 1;
        pthread_mutex_unlock(&lock);
        if (done)
            return;
        pause_ms(1);
    }
}

int main(void)
{
    pthread_t t;
    int round, all_in_time = 1, codes_ok = 1, conclusive = 0;
    vlInit();
    check("a 256^3 .vlb", sparse_vlb("big.vlb", 256, 256, 256));
    check("the second thread starts", pthread_create(&t, NULL, second, NULL) == 0);
    for (round = 1; round <= ROUNDS && conclusive < CONCLUSIVE; round++) {
        vlint e;
        vlLoad(1, "big.vlb"); /* again each round: its node values are made anew */
        vlInterpolationType(VL_NEAREST);
        vlScene();
        vlImage("round.ppm", 1.0f, 8, 8);
        vlObject();
        vlFunction(VL_O, field, NULL);
        vlEnd();
        pthread_mutex_lock(&lock);
        current = round;
        go = round;
        in_sample = 1;
        pthread_cond_broadcast(&changed);
        pthread_mutex_unlock(&lock);
        (void)vlSample(1, 0.5f, 0.5f, 0.5f); /* holds the library while it makes node values */
        pthread_mutex_lock(&lock);
        in_sample = 0;
        pthread_mutex_unlock(&lock);
        vlEnd(); /* renders at once */
        e = vlError();
        if (e != VL_NOERROR)
            printf("     (round %d: vlEnd reported %d)\n", round, (int)e);
        pthread_mutex_lock(&lock);
        while (returned != round)
            pthread_cond_wait(&changed, &lock);
        if (code != VL_NOERROR && code != VL_BADSCOPE)
            codes_ok = 0;
        conclusive += began_inside[round];
        pthread_mutex_unlock(&lock);
        if (!in_time[round]) {
            printf("     (round %d: the waiting call returned after the render)\n", round);
            all_in_time = 0;
        }
        vlUnload(1);
        vlInterpolationType(VL_TRILINEAR);
        remove("round.ppm");
        while (vlError() != VL_NOERROR)
            ;
    }
    pthread_mutex_lock(&lock);
    go = -1;
    pthread_cond_broadcast(&changed);
    pthread_mutex_unlock(&lock);
    pthread_join(t, NULL);
    remove("big.vlb");
    printf("     (%d rounds, %d with the call begun while the library was held)\n", round - 1,
           conclusive);
    check("calls began while the library was held", conclusive >= CONCLUSIVE);
    check("every waiting call returned while the render went on", all_in_time);
    check("with VL_BADSCOPE or VL_NOERROR", codes_ok);
    vlEnd();
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
